// SPDX-License-Identifier: MIT
// Rendering (src/tools/render/render.cpp): a shaded view and a heat map of a tiny hand-made scene, the
// colour ramp, and PNG output.
#include <gtest/gtest.h>

#include <limits>

#include <filesystem>
#include <fstream>
#include <set>

#include "spacebvh/error.hpp"
#include "spacebvh/tools/render.hpp"

namespace spacebvh {

using namespace spacebvh::tools;
namespace {

// A floor quad (two triangles in y = 0) and a tilted triangle standing on it, with a hand-built
// two-leaf tree, seen from above and in front.
struct TinyScene {
    Scene scene;
    Bvh bvh;
    Camera camera;
    TinyScene() {
        scene.name = "tiny";
        scene.triangles = {{{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}},
                           {{-1, 0, -1}, {1, 0, 1}, {-1, 0, 1}},
                           {{-0.5f, 0, 0}, {0.5f, 0, 0}, {0, 0.8f, -0.4f}}};
        AABB floor = merge(scene.triangles[0].bounds(), scene.triangles[1].bounds());
        AABB standing = scene.triangles[2].bounds();
        bvh.nodes = {{merge(floor, standing), 1, 0}, {floor, 0, 2}, {standing, 2, 1}};
        bvh.primitives = {0, 1, 2};
        bvh.builder = "hand";
        camera.eye = {0, 1.6f, 2.6f};
        camera.target = {0, 0.1f, 0};
        camera.fovy_degrees = 50;
    }
};

size_t distinct_colours(const Image& image, uint32_t rows) {
    std::set<std::array<uint8_t, 3>> colours;
    for (uint32_t y = 0; y < rows; ++y) {
        for (uint32_t x = 0; x < image.width; ++x) colours.insert(image.pixel(x, y));
    }
    return colours.size();
}

TEST(Render, ShadedImageShowsTheScene) {
    TinyScene t;
    Tracer tracer(t.scene, t.bvh, Kernel::binary);
    Image image = render_shaded(t.scene, tracer, t.camera, 48, 32);
    ASSERT_EQ(image.width, 48u);
    ASSERT_EQ(image.height, 32u);
    ASSERT_EQ(image.rgb.size(), 48u * 32u * 3u);
    // Background in the corners above the horizon, the floor and the standing triangle at two
    // different grey levels: at least three colours.
    EXPECT_EQ(image.pixel(0, 0), image.pixel(47, 0));
    EXPECT_GE(distinct_colours(image, image.height), 3u);
    EXPECT_NE(image.pixel(24, 16), image.pixel(0, 0));  // the centre hits geometry
}

TEST(Render, HeatmapHasCostVariationAndALegend) {
    TinyScene t;
    Tracer tracer(t.scene, t.bvh, Kernel::binary);
    HeatmapInfo info;
    Image image = render_heatmap(t.scene, tracer, t.camera, 64, 40, &info);
    ASSERT_GT(info.legend_height, 0u);
    ASSERT_EQ(image.width, 64u);
    ASSERT_EQ(image.height, 40u + info.legend_height);
    EXPECT_GE(info.scale_max, 1.0);
    EXPECT_GE(double(info.max_value), info.scale_max);
    EXPECT_GT(info.totals.nodes_visited, 0u);
    EXPECT_GT(info.totals.triangles_tested, 0u);
    EXPECT_GT(info.mean_value, 0.0);
    // Rays that miss everything cost less than rays through both leaves: the picture varies.
    EXPECT_GE(distinct_colours(image, 40), 2u);

    // The legend strip: its ramp runs from the bottom colour of the ramp to the top one, and it
    // carries light label ink.
    bool has_low = false, has_high = false, has_ink = false;
    for (uint32_t y = 40; y < image.height; ++y) {
        for (uint32_t x = 0; x < image.width; ++x) {
            auto c = image.pixel(x, y);
            has_low |= c == heatmap_colour(0.0);
            has_high |= c == heatmap_colour(1.0);
            has_ink |= c[0] > 200 && c[1] > 200 && c[2] > 200;
        }
    }
    EXPECT_TRUE(has_low);
    EXPECT_TRUE(has_high);
    EXPECT_TRUE(has_ink);

    HeatmapOptions no_legend;
    no_legend.legend = false;
    no_legend.quantity = HeatmapQuantity::nodes_visited;
    no_legend.percentile = 1.0;
    HeatmapInfo plain;
    Image bare = render_heatmap(t.scene, tracer, t.camera, 64, 40, &plain, no_legend);
    EXPECT_EQ(bare.height, 40u);
    EXPECT_EQ(plain.legend_height, 0u);
    EXPECT_EQ(plain.scale_max, double(plain.max_value));
    EXPECT_EQ(plain.totals.nodes_visited, info.totals.nodes_visited);
}

TEST(Render, ColourRampIsMonotoneInLightness) {
    auto luma = [](std::array<uint8_t, 3> c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; };
    double previous = -1.0;
    for (int i = 0; i <= 100; ++i) {
        double l = luma(heatmap_colour(i / 100.0));
        EXPECT_GE(l, previous - 0.5) << i;
        previous = l;
    }
    EXPECT_EQ(heatmap_colour(-1.0), heatmap_colour(0.0));
    EXPECT_EQ(heatmap_colour(2.0), heatmap_colour(1.0));
}

TEST(Render, WritesPngAndReportsErrors) {
    TinyScene t;
    Tracer tracer(t.scene, t.bvh, Kernel::binary);
    Image image = render_shaded(t.scene, tracer, t.camera, 16, 8);
    std::filesystem::path path = std::filesystem::temp_directory_path() / "spacebvh_test_render.png";
    write_png(path.string(), image);
    std::ifstream file(path, std::ios::binary);
    char signature[8] = {};
    file.read(signature, 8);
    EXPECT_EQ(std::string(signature + 1, 3), "PNG");
    file.close();
    std::filesystem::remove(path);

    EXPECT_THROW(write_png("/nonexistent-dir/x.png", image), Error);
    EXPECT_THROW(write_png(path.string(), Image{}), Error);
    EXPECT_THROW(render_shaded(t.scene, tracer, t.camera, 0, 8), Error);
    HeatmapOptions bad;
    bad.percentile = 0.0;
    EXPECT_THROW(render_heatmap(t.scene, tracer, t.camera, 8, 8, nullptr, bad), Error);
}

// A fixed colour scale (--scale-max) is used as given, so heat maps of two trees share one scale;
// a negative or infinite one is refused.
TEST(Render, HeatmapFixedScaleIsHonoured) {
    TinyScene t;
    const Tracer tracer(t.scene, t.bvh, Kernel::binary);
    HeatmapOptions fixed;
    fixed.scale_max = 1000.0;
    HeatmapInfo info;
    render_heatmap(t.scene, tracer, t.camera, 32, 24, &info, fixed);
    EXPECT_EQ(info.scale_max, 1000.0);
    HeatmapOptions negative;
    negative.scale_max = -1.0;
    EXPECT_THROW(render_heatmap(t.scene, tracer, t.camera, 8, 8, nullptr, negative), Error);
    HeatmapOptions infinite;
    infinite.scale_max = std::numeric_limits<double>::infinity();
    EXPECT_THROW(render_heatmap(t.scene, tracer, t.camera, 8, 8, nullptr, infinite), Error);
}

}  // namespace
}  // namespace spacebvh
