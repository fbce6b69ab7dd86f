// SPDX-License-Identifier: MIT
// Pictures of a scene through a tracer: a shaded view (to see what is traced) and a cost heat map
// (to see where the tree makes rays work), both with the primary rays of docs/rays.md.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "spacebvh/tools/scene.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh::tools {

// 8-bit RGB, row-major, row 0 at the top (the same pixel order as the primary rays).
struct Image {
    uint32_t width = 0, height = 0;
    std::vector<uint8_t> rgb;  // width * height * 3

    Image() = default;
    Image(uint32_t width_, uint32_t height_) : width(width_), height(height_), rgb(size_t(width_) * height_ * 3, 0) {}

    std::array<uint8_t, 3> pixel(uint32_t x, uint32_t y) const {
        const uint8_t* p = &rgb[(size_t(y) * width + x) * 3];
        return {p[0], p[1], p[2]};
    }
    void set_pixel(uint32_t x, uint32_t y, std::array<uint8_t, 3> colour) {
        uint8_t* p = &rgb[(size_t(y) * width + x) * 3];
        p[0] = colour[0];
        p[1] = colour[1];
        p[2] = colour[2];
    }
};

// Headlight shading: grey level from |dot(geometric normal, ray direction)|, a flat background
// colour for misses. Rows are traced in parallel on the calling thread's oneTBB arena.
// Throws Error for a zero or absurd image size (more than 16384 on a side) or a bad camera.
Image render_shaded(const Scene& scene, const Tracer& tracer, const Camera& camera, uint32_t width, uint32_t height);
// The same picture through any tracer (a scene of instances): `hit_normal(ray)` is the geometric
// normal (any length) of the triangle the ray's closest hit is on, nothing for a miss. Called from
// several threads at once.
Image render_shaded(const std::function<std::optional<Vec3>(const Ray&)>& hit_normal, const Camera& camera,
                    uint32_t width, uint32_t height);

enum class HeatmapQuantity {
    work,              // nodes visited + triangles tested (default)
    nodes_visited,     // box tests only
    triangles_tested,  // ray-triangle tests only
};

struct HeatmapOptions {
    HeatmapQuantity quantity = HeatmapQuantity::work;
    // The top of the colour ramp is this percentile of the per-pixel values (nearest rank), so that
    // a few extreme pixels do not wash out the picture; 1 = the maximum. Must be in (0, 1].
    double percentile = 0.99;
    // A fixed top of the colour ramp instead (> 0), so that heat maps of several trees share one
    // scale; 0 = from the percentile.
    double scale_max = 0.0;
    // Appends a legend strip below the width x height picture: the colour ramp with tick labels.
    bool legend = true;
};

// "work", "nodes" or "triangles" (the CLI's --quantity); throws Error for another name.
HeatmapQuantity parse_heatmap_quantity(const std::string& name);
// Throws Error unless percentile is in (0, 1] and scale_max finite and >= 0 (render_heatmap calls it).
void validate(const HeatmapOptions& options);

struct HeatmapInfo {
    double scale_max = 0;        // the value drawn with the top colour (values above are clamped)
    uint64_t max_value = 0;      // the largest per-pixel value
    double mean_value = 0;       // mean per-pixel value
    TraversalStats totals;       // summed over all pixels
    uint32_t legend_height = 0;  // rows appended below the picture (0 without legend)
};

// Per-pixel traversal cost (closest-hit primary rays) in a perceptual colour ramp (viridis-like,
// dark = cheap, yellow = expensive). The image is width x (height + legend rows).
Image render_heatmap(const Scene& scene, const Tracer& tracer, const Camera& camera, uint32_t width, uint32_t height,
                     HeatmapInfo* info = nullptr, const HeatmapOptions& options = {});

// The heat map's colour ramp at t in [0, 1] (clamped).
std::array<uint8_t, 3> heatmap_colour(double t);

// Writes a PNG file. Throws Error naming the file when it cannot be written or the image is invalid.
void write_png(const std::string& path, const Image& image);

}  // namespace spacebvh::tools
