// SPDX-License-Identifier: MIT
// Internal pieces shared by the scene loaders (not installed): file reading, error formatting,
// number parsing and the load-time transform as a precomputed matrix.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "spacebvh/error.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::tools::scene_detail {

// Whole file in memory: the largest shared scene is 35 MB, and one buffer makes parsing simple and fast.
std::string read_file_bytes(const std::string& path);

// "path:line: what" (text formats) and "path: where: what" (binary formats).
[[noreturn]] void fail_at_line(const std::string& path, size_t line, const std::string& what);
[[noreturn]] void fail_at(const std::string& path, const std::string& where, const std::string& what);

enum class NumberStatus { ok, malformed, out_of_range, not_finite };

// Parses a whole token as float32 (correctly rounded by std::from_chars). A leading '+' is accepted
// because some exporters write it; underflow becomes 0 or a denormal; NaN/inf are reported, not returned.
inline NumberStatus parse_float(std::string_view text, float& out) {
    const char* first = text.data();
    const char* last = first + text.size();
    if (first != last && *first == '+') {
        ++first;
        if (first != last && *first == '-') return NumberStatus::malformed;
    }
    if (first == last) return NumberStatus::malformed;
    auto [ptr, ec] = std::from_chars(first, last, out);
    if (ec == std::errc::result_out_of_range) {
        // libstdc++ reports underflow as out of range too; tiny values are legitimate coordinates.
        double wide = 0.0;
        auto [wide_ptr, wide_ec] = std::from_chars(first, last, wide);
        if (wide_ec == std::errc() && wide_ptr == last && std::fabs(wide) < 1.0) {
            out = static_cast<float>(wide);
            return NumberStatus::ok;
        }
        return NumberStatus::out_of_range;
    }
    if (ec != std::errc() || ptr != last) return NumberStatus::malformed;
    if (!std::isfinite(out)) return NumberStatus::not_finite;
    return NumberStatus::ok;
}

inline const char* describe(NumberStatus status) {
    switch (status) {
        case NumberStatus::ok:
            return "ok";
        case NumberStatus::malformed:
            return "malformed number";
        case NumberStatus::out_of_range:
            return "number out of float range";
        case NumberStatus::not_finite:
            return "NaN or infinite number";
    }
    return "bad number";
}

// Stores through a volatile so the value is rounded to float32 here: GCC contracts a*b+c into a fused
// multiply-add by default (-ffp-contract=fast) when -march=native enables FMA, which changes the last
// bit of results that docs/rays.md requires to be computed unfused.
inline float unfused(float value) {
    volatile float stored = value;
    return stored;
}

// Triangle::is_degenerate() over all triangles.
size_t count_degenerate(const std::vector<Triangle>& triangles);

// Quotes a token for an error message, shortened so that binary garbage cannot flood the message.
std::string quote_token(std::string_view token);

// p' = translate + scale * (Rz(c) * Ry(b) * Rx(a) * p), evaluated in double and rounded once to float.
// Precomputed so that loading 2.4M corners does not recompute sines; SceneTransform::apply uses it too,
// so both give bit-identical results.
struct TransformMatrix {
    double m[3][3];  // rotation, already multiplied by the scale
    double t[3];

    explicit TransformMatrix(const SceneTransform& transform);
    Vec3 apply(Vec3 p) const {
        double x = p.x, y = p.y, z = p.z;
        return {static_cast<float>(t[0] + (m[0][0] * x + m[0][1] * y + m[0][2] * z)),
                static_cast<float>(t[1] + (m[1][0] * x + m[1][1] * y + m[1][2] * z)),
                static_cast<float>(t[2] + (m[2][0] * x + m[2][1] * y + m[2][2] * z))};
    }
};

// Format readers: each returns the triangles in file order, before the load transform.
std::vector<Triangle> load_obj(const std::string& path);
std::vector<Triangle> load_ply(const std::string& path);
std::vector<Triangle> load_gltf(const std::string& path);  // .gltf and .glb

// builtin:city:N (city_scene.cpp): N, checked to lie in [kMinCityTriangles, kMaxCityTriangles], and
// the city of about N triangles (within a fraction of a percent from 10^4 triangles up).
inline constexpr uint64_t kMinCityTriangles = 100;
inline constexpr uint64_t kMaxCityTriangles = 2'000'000'000;
uint64_t parse_city_size(const std::string& text);
std::vector<Triangle> make_city(uint64_t target_triangles);
Camera city_camera(uint64_t target_triangles);

// The same readers over a file's bytes already in memory (the fuzz harnesses feed them directly).
// `path` names the input in error messages; parse_gltf also takes from it the extension (.glb
// requires the GLB container) and the folder that external buffer URIs are relative to.
std::vector<Triangle> parse_obj(std::string_view data, const std::string& path);
std::vector<Triangle> parse_ply(std::string_view data, const std::string& path);
std::vector<Triangle> parse_gltf(std::string_view bytes, const std::string& path);

// Built-in scenes' own cameras (in the builtin's coordinates), if they define one.
std::optional<Camera> builtin_camera(const std::string& name);

}  // namespace spacebvh::tools::scene_detail
