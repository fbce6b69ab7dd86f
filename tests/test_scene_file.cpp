// SPDX-License-Identifier: MIT
// Scene files: a saved and loaded RenderScene answers as the saved one (t, primitive, geometry and
// instance path, under masks) and as the exact arbiter; truncated, corrupted and altered files give
// errors that name the source and the fault.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "scene_test_support.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/scene_file.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tree_file.hpp"
#include "test_support.hpp"
#include "tree_file/tree_file_checksum.hpp"

using namespace spacebvh;
using namespace spacebvh::scene_testing;

namespace {

Affine placed(float degrees, Vec3 scale, Vec3 shift) {
    const double c = std::cos(degrees * M_PI / 180.0), s = std::sin(degrees * M_PI / 180.0);
    Affine a;
    a.m = {float(scale.x * c),
           float(-s * scale.y),
           0,
           shift.x,
           float(scale.x * s),
           float(c * scale.y),
           0,
           shift.y,
           0,
           0,
           scale.z,
           shift.z};
    return a;
}

// Two levels: a spatial-split mesh instanced mirrored, rotated and non-uniformly scaled, beside a
// mesh, a hidden mesh and a detached slot in the top scene.
struct TwoLevels {
    std::vector<Triangle> mesh = organic(2500), small = organic(400);
    Level leaf, top;
    float size;
    TwoLevels() : leaf(config("spatial"), "leaf"), top(config("binned"), "top") {
        leaf.mesh(mesh);
        leaf.scene->commit();
        size = length(bounds_of(mesh).extent());
        top.mesh(small, 0x2);
        const uint32_t gone = top.scene->attach_mesh(MeshView(small));
        top.scene->detach(gone);
        top.instance(leaf, placed(35.0f, {-1.0f, 1.4f, 0.7f}, {size * 0.6f, 0, 0}), 0x1);
        top.instance(leaf, placed(-80.0f, {0.8f, 0.8f, 1.2f}, {0, size * 0.5f, 0}), 0x3);
        top.scene->commit();
    }
    static SceneConfig config(const char* builder) {
        SceneConfig c;
        c.recipe = TreeRecipe::for_builder(builder);
        return c;
    }
};

std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(SceneFile, LoadedSceneAnswersAsTheSavedOneAndTheArbiter) {
    TwoLevels scene;
    const std::vector<std::byte> bytes = serialize_render_scene(*scene.top.scene, "flags");
    SceneFileInfo info;
    const std::shared_ptr<RenderScene> loaded = deserialize_render_scene(bytes, "memory", {}, &info);
    EXPECT_EQ(info.scene_count, 2u);
    EXPECT_EQ(info.mesh_count, 2u);
    EXPECT_EQ(info.instance_count, 2u);
    EXPECT_EQ(info.triangle_count, 2900u);
    EXPECT_EQ(info.settings, "flags");
    EXPECT_EQ(loaded->name(), "top");
    EXPECT_EQ(loaded->geometry_count(), scene.top.scene->geometry_count());
    EXPECT_EQ(loaded->depth(), 1u);
    const std::vector<Placement> all = placements(scene.top);
    const std::vector<Ray> rays = tools::generate_random_rays(scene.top.scene->bounds(), 400, 5);
    size_t differ = 0, wrong = 0, hits = 0;
    for (const Ray& ray : rays)
        for (const uint32_t mask : {0xFFFFFFFFu, 0x1u, 0x2u}) {
            const SceneHit a = scene.top.scene->intersect(ray, {mask}), b = loaded->intersect(ray, {mask});
            differ += a.t != b.t || a.primitive != b.primitive || a.geometry != b.geometry ||
                      a.instance != b.instance || a.u != b.u || a.v != b.v;
            differ += scene.top.scene->occluded(ray, {mask}) != loaded->occluded(ray, {mask});
            const Reference truth = closest_in_instances(all, ray, mask);
            wrong += !tools::hits_agree(record_of(b), record_of(truth), ray, scene.size);
            hits += b.is_hit();
        }
    EXPECT_EQ(differ, 0u);
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(hits, 20u);
    // Saving the loaded scene gives the same bytes: nothing is lost or reordered.
    EXPECT_EQ(serialize_render_scene(*loaded, "flags"), bytes);
}

TEST(SceneFile, FilesKernelsAndRefitOfALoadedScene) {
    TwoLevels scene;
    const std::string path = (std::filesystem::temp_directory_path() / "spacebvh_test_scene.sbvh").string();
    save_render_scene(path, *scene.top.scene);
    EXPECT_TRUE(is_scene_file(path));
    SceneLoadOptions binary;
    binary.tracer = TracerConfig{};
    binary.tracer->kernel = Kernel::binary;
    const std::shared_ptr<RenderScene> loaded = load_render_scene(path, binary);
    EXPECT_EQ(loaded->config().tracer.kernel, Kernel::binary);
    const std::vector<Ray> rays = tools::generate_random_rays(scene.top.scene->bounds(), 200, 8);
    for (const Ray& ray : rays)
        EXPECT_TRUE(tools::hits_agree(record_of(scene.top.scene->intersect(ray)), record_of(loaded->intersect(ray)),
                                      ray, scene.size));
    // A loaded scene owns its triangles: refit re-reads them and changes nothing.
    loaded->refit(0);
    for (const Ray& ray : rays) EXPECT_EQ(scene.top.scene->occluded(ray), loaded->occluded(ray));
    // A one-mesh tree file is not a scene file, and the reverse.
    const std::string tree = path + ".tree";
    save_bvh(tree, build(MeshView(scene.small), TreeRecipe::for_builder("binned")), scene.small);
    EXPECT_FALSE(is_scene_file(tree));
    EXPECT_NE(error_of([&] { load_render_scene(tree); }).find("not a spacebvh scene file"), std::string::npos);
    EXPECT_NE(error_of([&] { load_bvh(path, scene.small); }).find("not a spacebvh tree file"), std::string::npos);
    std::filesystem::remove(path);
    std::filesystem::remove(tree);
    EXPECT_NE(error_of([&] { load_render_scene(path); }).find(path), std::string::npos);
}

TEST(SceneFile, UncommittedOrStaleScenesAreNotSaved) {
    RenderScene empty({}, "empty");
    EXPECT_NE(error_of([&] { serialize_render_scene(empty); }).find("not committed"), std::string::npos);
    TwoLevels scene;
    scene.leaf.scene->refit(0);  // the top scene now holds stale boxes until its own refit()
    EXPECT_NE(error_of([&] { serialize_render_scene(*scene.top.scene); }).find("refitted since"), std::string::npos);
    scene.top.scene->refit();
    EXPECT_NO_THROW(serialize_render_scene(*scene.top.scene));
}

// Every truncation and every single flipped byte (sampled) gives an Error naming the source; no
// crash, no scene.
TEST(SceneFile, TruncatedAndCorruptedFilesGiveClearErrors) {
    TwoLevels scene;
    const std::vector<std::byte> bytes = serialize_render_scene(*scene.top.scene);
    for (size_t size = 0; size < bytes.size(); size += 1 + size / 3) {
        const std::string e = error_of([&] { deserialize_render_scene(std::span(bytes).first(size), "cut.sbvh"); });
        EXPECT_EQ(e.rfind("cut.sbvh: ", 0), 0u) << size << ": " << e;
        EXPECT_TRUE(e.find("truncated") != std::string::npos || e.find("too short") != std::string::npos) << e;
    }
    for (size_t at = 0; at < bytes.size(); at += 1 + at / 5) {
        std::vector<std::byte> bad = bytes;
        bad[at] ^= std::byte{0x10};
        const std::string e = error_of([&] { deserialize_render_scene(bad, "flip.sbvh"); });
        EXPECT_EQ(e.rfind("flip.sbvh: ", 0), 0u) << at << ": " << e;
    }
    std::vector<std::byte> longer = bytes;
    longer.push_back(std::byte{0});
    EXPECT_NE(error_of([&] { deserialize_render_scene(longer, "long"); }).find("past the end"), std::string::npos);
    std::vector<std::byte> version = bytes;
    version[8] = std::byte{9};
    EXPECT_NE(error_of([&] { deserialize_render_scene(version, "v"); }).find("format version 9"), std::string::npos);
}

// Damage past the checksum (the checksum repaired, as a deliberate edit would): still an Error
// naming what is wrong, or a scene that answers as the arbiter; never a crash.
TEST(SceneFile, AlteredFilesWithARepairedChecksumAreRefusedOrStillExact) {
    TwoLevels scene;
    const std::vector<std::byte> bytes = serialize_render_scene(*scene.top.scene);
    const auto repaired = [](std::vector<std::byte> b) {
        const uint64_t sum = tree_file_detail::checksum(std::span(b).first(b.size() - 8));
        std::memcpy(b.data() + b.size() - 8, &sum, 8);
        return b;
    };
    // The first instance's transform made singular: its third row zeroed.
    std::vector<std::byte> singular = bytes;
    const float row[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    const float first = placed(35.0f, {-1.0f, 1.4f, 0.7f}, {scene.size * 0.6f, 0, 0}).m[0];
    size_t at = 0;
    for (size_t k = 0; k + 48 <= bytes.size(); k += 4)
        if (std::memcmp(bytes.data() + k, &first, 4) == 0) at = k;
    ASSERT_GT(at, 0u);
    std::memcpy(singular.data() + at + 32, row, 16);
    EXPECT_NE(error_of([&] { deserialize_render_scene(repaired(singular), "s"); }).find("singular"), std::string::npos);
    const std::vector<Ray> rays = tools::generate_random_rays(scene.top.scene->bounds(), 40, 6);
    size_t refused = 0, loaded = 0;
    for (size_t k = 40; k + 8 < bytes.size(); k += 1 + k / 9) {
        std::vector<std::byte> bad = bytes;
        bad[k] ^= std::byte{0x41};
        std::shared_ptr<RenderScene> s;
        const std::string e = error_of([&] { s = deserialize_render_scene(repaired(bad), "edit"); });
        if (!s) {
            EXPECT_EQ(e.rfind("edit: ", 0), 0u) << k << ": " << e;
            ++refused;
            continue;
        }
        ++loaded;  // a byte the answers do not depend on (a mask bit, a box the load recomputes) or a moved vertex
        for (const Ray& ray : rays) (void)s->intersect(ray);
    }
    EXPECT_GT(refused, 10u);
    EXPECT_GT(refused + loaded, 40u);
}

}  // namespace
