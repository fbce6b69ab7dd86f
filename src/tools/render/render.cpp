// SPDX-License-Identifier: MIT
// Shaded views and traversal-cost heat maps (see spacebvh/tools/render.hpp), and PNG output through
// stb_image_write.
#include "spacebvh/tools/render.hpp"

#include <algorithm>
#include <functional>
#include <optional>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "spacebvh/error.hpp"
#include "spacebvh/tools/rays.hpp"

// Static linkage keeps stb's symbols private to this file; its own code is not ours to warn about.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>
#pragma GCC diagnostic pop

namespace spacebvh::tools {
namespace {

constexpr std::array<uint8_t, 3> kBackground{38, 42, 52};
constexpr std::array<uint8_t, 3> kLegendBackground{24, 24, 24};
constexpr std::array<uint8_t, 3> kLegendInk{235, 235, 235};

void check_size(uint32_t width, uint32_t height, const char* what) {
    if (width == 0 || height == 0 || width > kMaxImageSide || height > kMaxImageSide) {
        throw Error(std::string(what) + ": image size must be between 1 and " + std::to_string(kMaxImageSide) +
                    " on each side, got " + std::to_string(width) + " x " + std::to_string(height));
    }
}

uint8_t to_byte(double value) { return uint8_t(std::lround(std::clamp(value, 0.0, 255.0))); }

// --- A 5x7 bitmap font for the legend's numbers. Each glyph is 7 rows of 5 bits, bit 4 = left. ---
struct Glyph {
    char c;
    std::array<uint8_t, 7> rows;
};
constexpr int kGlyphWidth = 5, kGlyphHeight = 7;
constexpr Glyph kGlyphs[] = {
    {'0', {0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110}},
    {'1', {0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110}},
    {'2', {0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111}},
    {'3', {0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110}},
    {'4', {0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010}},
    {'5', {0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110}},
    {'6', {0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110}},
    {'7', {0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000}},
    {'8', {0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110}},
    {'9', {0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100}},
    {'+', {0b00000, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0b00000}},
};

const Glyph* find_glyph(char c) {
    for (const Glyph& g : kGlyphs) {
        if (g.c == c) return &g;
    }
    return nullptr;
}

// Width in pixels of text drawn at `scale` (one blank column between glyphs).
int text_width(const std::string& text, int scale) {
    return text.empty() ? 0 : int(text.size()) * (kGlyphWidth + 1) * scale - scale;
}

void draw_text(Image& image, int x0, int y0, const std::string& text, int scale, std::array<uint8_t, 3> ink) {
    for (size_t i = 0; i < text.size(); ++i) {
        const Glyph* glyph = find_glyph(text[i]);
        if (!glyph) continue;
        int gx = x0 + int(i) * (kGlyphWidth + 1) * scale;
        for (int row = 0; row < kGlyphHeight; ++row) {
            for (int col = 0; col < kGlyphWidth; ++col) {
                if (!(glyph->rows[row] >> (kGlyphWidth - 1 - col) & 1)) continue;
                for (int dy = 0; dy < scale; ++dy) {
                    for (int dx = 0; dx < scale; ++dx) {
                        int x = gx + col * scale + dx, y = y0 + row * scale + dy;
                        if (x >= 0 && y >= 0 && x < int(image.width) && y < int(image.height)) {
                            image.set_pixel(uint32_t(x), uint32_t(y), ink);
                        }
                    }
                }
            }
        }
    }
}

void fill_rect(Image& image, int x0, int y0, int x1, int y1, std::array<uint8_t, 3> colour) {
    for (int y = std::max(y0, 0); y < std::min(y1, int(image.height)); ++y) {
        for (int x = std::max(x0, 0); x < std::min(x1, int(image.width)); ++x)
            image.set_pixel(uint32_t(x), uint32_t(y), colour);
    }
}

// The smallest 1, 2 or 5 times a power of ten that is >= raw (and >= 1: the values are counts).
double nice_step(double raw) {
    if (raw <= 1.0) return 1.0;
    double power = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 5.0, 10.0}) {
        if (m * power >= raw) return m * power;
    }
    return 10.0 * power;
}

// Legend layout, in units of the font scale s: padding 3, ramp 8, tick 3, gap 1, label 7, padding 3.
int legend_scale(uint32_t width) { return std::clamp(int(width) / 480, 1, 3); }
uint32_t legend_height(uint32_t width) { return uint32_t(25 * legend_scale(width)); }

// Draws the ramp from 0 to scale_max across the strip starting at row y0, with tick labels at
// round values; "+" after the last label when some pixels were above scale_max (clamped).
void draw_legend(Image& image, uint32_t y0, double scale_max, bool clamped) {
    const int s = legend_scale(image.width);
    const int top = int(y0);
    fill_rect(image, 0, top, int(image.width), int(image.height), kLegendBackground);

    const int margin = 4 * s;
    const int bar_x0 = margin, bar_x1 = int(image.width) - margin;  // [x0, x1)
    if (bar_x1 - bar_x0 < 2) return;
    const int bar_y0 = top + 3 * s, bar_y1 = bar_y0 + 8 * s;
    const int bar_width = bar_x1 - bar_x0;
    for (int x = bar_x0; x < bar_x1; ++x) {
        double t = bar_width > 1 ? double(x - bar_x0) / double(bar_width - 1) : 0.0;
        fill_rect(image, x, bar_y0, x + 1, bar_y1, heatmap_colour(t));
    }

    // As many round-valued ticks as fit with their labels side by side.
    auto label_of = [](double value) { return std::to_string(uint64_t(std::llround(value))); };
    const int label_room = text_width(label_of(scale_max), s) + 3 * (kGlyphWidth + 1) * s;
    const int max_ticks = std::max(1, bar_width / std::max(1, label_room));
    const double step = nice_step(scale_max / max_ticks);
    const int tick_y0 = bar_y1, tick_y1 = bar_y1 + 3 * s, label_y = tick_y1 + s;
    int last_label_end = -1;
    for (double value = 0.0; value <= scale_max + 1e-9; value += step) {
        int x = bar_x0 + int(std::lround(value / scale_max * double(bar_width - 1)));
        fill_rect(image, x - (s - 1) / 2, tick_y0, x - (s - 1) / 2 + s, tick_y1, kLegendInk);
        std::string label = label_of(value);
        int width = text_width(label, s);
        int lx = std::clamp(x - width / 2, 0, std::max(0, int(image.width) - width));
        if (lx <= last_label_end + 2 * s) continue;  // would touch the previous label
        draw_text(image, lx, label_y, label, s, kLegendInk);
        last_label_end = lx + width;
    }
    if (clamped) {
        // "+" at the right end of the ramp: its top colour also stands for everything above.
        int width = text_width("+", s);
        int lx = int(image.width) - width;
        if (lx > last_label_end + 2 * s) draw_text(image, lx, label_y, "+", s, kLegendInk);
    }
}

uint64_t quantity_of(const TraversalStats& stats, HeatmapQuantity quantity) {
    switch (quantity) {
        case HeatmapQuantity::nodes_visited:
            return stats.nodes_visited;
        case HeatmapQuantity::triangles_tested:
            return stats.triangles_tested;
        case HeatmapQuantity::work:
            break;
    }
    return stats.nodes_visited + stats.triangles_tested;
}

}  // namespace

// Viridis (van der Walt & Smith, matplotlib 2015): perceptually uniform and readable in greyscale
// and by colour-blind viewers. Ten evenly spaced samples, linearly interpolated in sRGB.
std::array<uint8_t, 3> heatmap_colour(double t) {
    static constexpr std::array<std::array<double, 3>, 10> kRamp{{{68, 1, 84},
                                                                  {72, 40, 120},
                                                                  {62, 74, 137},
                                                                  {49, 104, 142},
                                                                  {38, 130, 142},
                                                                  {31, 158, 137},
                                                                  {53, 183, 121},
                                                                  {110, 206, 88},
                                                                  {181, 222, 43},
                                                                  {253, 231, 37}}};
    if (!(t > 0.0)) t = 0.0;  // also NaN
    t = std::min(t, 1.0) * double(kRamp.size() - 1);
    size_t i = std::min(size_t(t), kRamp.size() - 2);
    double f = t - double(i);
    std::array<uint8_t, 3> colour;
    for (int k = 0; k < 3; ++k) colour[k] = to_byte(kRamp[i][k] + f * (kRamp[i + 1][k] - kRamp[i][k]));
    return colour;
}

Image render_shaded(const Scene& scene, const Tracer& tracer, const Camera& camera, uint32_t width, uint32_t height) {
    return render_shaded(
        [&](const Ray& ray) -> std::optional<Vec3> {
            const Hit hit = tracer.intersect(ray);
            if (!hit.is_hit()) return std::nullopt;
            return scene.triangles[hit.primitive].geometric_normal();
        },
        camera, width, height);
}

Image render_shaded(const std::function<std::optional<Vec3>(const Ray&)>& hit_normal, const Camera& camera,
                    uint32_t width, uint32_t height) {
    check_size(width, height, "render_shaded");
    const std::vector<Ray> rays = generate_primary_rays(camera, width, height);
    Image image(width, height);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, height), [&](const tbb::blocked_range<uint32_t>& rows) {
        for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
            for (uint32_t x = 0; x < width; ++x) {
                const Ray& ray = rays[size_t(y) * width + x];
                const std::optional<Vec3> normal = hit_normal(ray);
                if (!normal) {
                    image.set_pixel(x, y, kBackground);
                    continue;
                }
                // Headlight: surfaces facing the camera are bright, grazing ones dark; either side.
                const Vec3 n = *normal;
                double nn = std::sqrt(double(dot(n, n))), dd = std::sqrt(double(dot(ray.dir, ray.dir)));
                double c = (nn > 0.0 && dd > 0.0) ? std::abs(double(dot(n, ray.dir))) / (nn * dd) : 0.0;
                double level = 0.12 + 0.88 * std::min(c, 1.0);
                image.set_pixel(x, y, {to_byte(255.0 * level), to_byte(246.0 * level), to_byte(232.0 * level)});
            }
        }
    });
    return image;
}

HeatmapQuantity parse_heatmap_quantity(const std::string& name) {
    if (name == "work") return HeatmapQuantity::work;
    if (name == "nodes") return HeatmapQuantity::nodes_visited;
    if (name == "triangles") return HeatmapQuantity::triangles_tested;
    throw Error("heat map quantity must be work, nodes or triangles, got '" + name + "'");
}

void validate(const HeatmapOptions& options) {
    if (!(options.percentile > 0.0 && options.percentile <= 1.0))
        throw Error("render_heatmap: percentile must be in (0, 1], got " + std::to_string(options.percentile));
    if (!(options.scale_max >= 0.0) || std::isinf(options.scale_max))
        throw Error("render_heatmap: scale_max must be finite and >= 0, got " + std::to_string(options.scale_max));
}

Image render_heatmap(const Scene& scene, const Tracer& tracer, const Camera& camera, uint32_t width, uint32_t height,
                     HeatmapInfo* info, const HeatmapOptions& options) {
    check_size(width, height, "render_heatmap");
    validate(options);
    const std::vector<Ray> rays = generate_primary_rays(camera, width, height);
    const size_t pixels = rays.size();
    std::vector<TraversalStats> per_pixel(pixels);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, height), [&](const tbb::blocked_range<uint32_t>& rows) {
        for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
            for (uint32_t x = 0; x < width; ++x) {
                size_t i = size_t(y) * width + x;
                tracer.intersect(rays[i], per_pixel[i]);
            }
        }
    });

    std::vector<uint64_t> values(pixels);
    HeatmapInfo result;
    double sum = 0.0;
    for (size_t i = 0; i < pixels; ++i) {
        values[i] = quantity_of(per_pixel[i], options.quantity);
        result.totals += per_pixel[i];
        result.max_value = std::max(result.max_value, values[i]);
        sum += double(values[i]);
    }
    result.mean_value = sum / double(pixels);
    if (options.scale_max > 0.0) {
        result.scale_max = options.scale_max;  // fixed, so pictures of several trees compare directly
    } else {
        // Nearest-rank percentile: the smallest value with at least percentile * N values <= it.
        std::vector<uint64_t> sorted = values;
        size_t rank = size_t(std::ceil(options.percentile * double(pixels)));
        size_t index = std::clamp<size_t>(rank, 1, pixels) - 1;
        std::nth_element(sorted.begin(), sorted.begin() + index, sorted.end());
        result.scale_max = std::max(1.0, double(sorted[index]));
    }

    result.legend_height = options.legend ? legend_height(width) : 0;
    Image image(width, height + result.legend_height);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, height), [&](const tbb::blocked_range<uint32_t>& rows) {
        for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
            for (uint32_t x = 0; x < width; ++x) {
                image.set_pixel(x, y, heatmap_colour(double(values[size_t(y) * width + x]) / result.scale_max));
            }
        }
    });
    if (options.legend) draw_legend(image, height, result.scale_max, double(result.max_value) > result.scale_max);
    if (info) *info = result;
    (void)scene;  // the scene is implied by the tracer; kept for symmetry with render_shaded
    return image;
}

void write_png(const std::string& path, const Image& image) {
    if (image.width == 0 || image.height == 0 || image.rgb.size() != size_t(image.width) * image.height * 3) {
        throw Error("cannot write PNG '" + path + "': the image is empty or its pixel buffer has the wrong size");
    }
    errno = 0;
    int ok =
        stbi_write_png(path.c_str(), int(image.width), int(image.height), 3, image.rgb.data(), int(image.width) * 3);
    if (!ok) {
        std::string reason = errno ? std::strerror(errno) : "write failed";
        throw Error("cannot write PNG '" + path + "': " + reason);
    }
}

}  // namespace spacebvh::tools
