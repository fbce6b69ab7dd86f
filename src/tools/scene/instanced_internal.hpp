// SPDX-License-Identifier: MIT
// Internal pieces of the instanced scenes (not installed): transforms composed in double, the forest
// and the glTF node reader.
#pragma once

#include <array>
#include <cmath>
#include <string>
#include <string_view>

#include "spacebvh/tools/instanced_scene.hpp"
#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools::scene_detail {

// An affine transform in double, row-major 3x4 [A | b] as Affine: levels are composed in double and
// rounded to float once, so a composed transform does not gather one rounding per level.
struct Affine64 {
    std::array<double, 12> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

    Affine64() = default;
    explicit Affine64(const Affine& a) {
        for (int i = 0; i < 12; ++i) m[i] = a.m[i];
    }
    static Affine64 from_transform(const SceneTransform& transform) {
        const TransformMatrix t(transform);
        Affine64 r;
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) r.m[4 * i + j] = t.m[i][j];
            r.m[4 * i + 3] = t.t[i];
        }
        return r;
    }
    // From glTF's column-major 4x4 (the last row is (0, 0, 0, 1) by the glTF rules and ignored).
    static Affine64 from_column_major(const std::array<double, 16>& c) {
        Affine64 r;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 4; ++j) r.m[4 * i + j] = c[4 * j + i];
        return r;
    }
    Affine64 operator*(const Affine64& b) const {
        Affine64 r;
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 4; ++j) {
                double sum = j == 3 ? m[4 * i + 3] : 0.0;
                for (int k = 0; k < 3; ++k) sum += m[4 * i + k] * b.m[4 * k + j];
                r.m[4 * i + j] = sum;
            }
        }
        return r;
    }
    bool is_finite() const {
        for (double v : m)
            if (!std::isfinite(v)) return false;
        return true;
    }
    double determinant() const {
        return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
               m[2] * (m[4] * m[9] - m[5] * m[8]);
    }
    Affine rounded() const {
        Affine a;
        for (int i = 0; i < 12; ++i) a.m[i] = static_cast<float>(m[i]);
        return a;
    }
};

// Why a transform cannot place an instance (RenderScene's rules, checked at load so that the error
// names the file's node rather than a geometry id), or "" when it can: an entry NaN or infinite (a
// double beyond float range rounds to infinity), a zero determinant, or a condition number
// ||A|| ||A^-1|| (infinity norms) above 65536.
std::string invalid_instance_transform(const Affine& transform);

// builtin:forest:N (forest_scene.cpp).
inline constexpr std::string_view kForestPrefix = "builtin:forest:";
uint64_t parse_forest_size(std::string_view text);
InstancedScene make_forest(uint64_t instances);

// A .gltf / .glb file as an instanced scene (gltf_instancing.cpp), and the same over bytes in memory
// (the fuzz harness); `path` names the input and gives the folder of external buffers.
InstancedScene load_gltf_instanced(const std::string& path);
InstancedScene parse_gltf_instanced(std::string_view bytes, const std::string& path);

}  // namespace spacebvh::tools::scene_detail
