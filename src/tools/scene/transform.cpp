// SPDX-License-Identifier: MIT
// The load-time transform (docs/rays.md, "Scene conventions"): R = Rz(c) * Ry(b) * Rx(a),
// degrees, about the origin; then scale; then translate.
#include <cctype>
#include <cmath>
#include <numbers>

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools {
namespace {

// Exact values at multiples of 90 degrees, so that e.g. a 90-degree turn maps axes onto axes exactly
// (std::cos(pi/2) is 6e-17, not 0).
void sin_cos_degrees(double degrees, double& s, double& c) {
    double reduced = std::fmod(degrees, 360.0);
    if (reduced < 0) reduced += 360.0;
    if (reduced == 0.0) {
        s = 0;
        c = 1;
        return;
    }
    if (reduced == 90.0) {
        s = 1;
        c = 0;
        return;
    }
    if (reduced == 180.0) {
        s = 0;
        c = -1;
        return;
    }
    if (reduced == 270.0) {
        s = -1;
        c = 0;
        return;
    }
    double radians = degrees * (std::numbers::pi / 180.0);
    s = std::sin(radians);
    c = std::cos(radians);
}

using Mat3 = std::array<std::array<double, 3>, 3>;

Mat3 multiply(const Mat3& a, const Mat3& b) {
    Mat3 r{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
    return r;
}

}  // namespace

namespace scene_detail {

TransformMatrix::TransformMatrix(const SceneTransform& transform) {
    double sa, ca, sb, cb, sc, cc;
    sin_cos_degrees(transform.rotate_degrees.x, sa, ca);
    sin_cos_degrees(transform.rotate_degrees.y, sb, cb);
    sin_cos_degrees(transform.rotate_degrees.z, sc, cc);
    const Mat3 rx{{{1, 0, 0}, {0, ca, -sa}, {0, sa, ca}}};
    const Mat3 ry{{{cb, 0, sb}, {0, 1, 0}, {-sb, 0, cb}}};
    const Mat3 rz{{{cc, -sc, 0}, {sc, cc, 0}, {0, 0, 1}}};
    const Mat3 r = multiply(rz, multiply(ry, rx));
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m[i][j] = r[i][j] * static_cast<double>(transform.scale);
    t[0] = transform.translate.x;
    t[1] = transform.translate.y;
    t[2] = transform.translate.z;
}

}  // namespace scene_detail

Vec3 SceneTransform::apply(Vec3 p) const { return scene_detail::TransformMatrix(*this).apply(p); }

const char* SceneTransform::invalid_reason() const {
    if (!std::isfinite(scale) || scale == 0.0f) return "scale must be a finite non-zero number";
    if (!is_finite(translate)) return "translate must be finite";
    return nullptr;
}

Vec3 SceneTransform::parse_rotation(const std::string& text) {
    auto fail = [&](const std::string& why) -> Vec3 {
        throw Error("bad rotation '" + text + "' (expected e.g. x:45,y:45,z:45): " + why);
    };
    Vec3 degrees(0.0f);
    bool seen[3] = {false, false, false};
    size_t pos = 0;
    auto trim = [](std::string_view s) {
        while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
        while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
        return s;
    };
    if (trim(text).empty()) return degrees;  // "any subset" includes none
    while (pos <= text.size()) {
        size_t comma = text.find(',', pos);
        if (comma == std::string::npos) comma = text.size();
        std::string_view part = trim(std::string_view(text).substr(pos, comma - pos));
        size_t colon = part.find(':');
        if (colon == std::string_view::npos) fail("item '" + std::string(part) + "' has no ':'");
        std::string_view axis_name = trim(part.substr(0, colon));
        std::string_view value_text = trim(part.substr(colon + 1));
        int axis = -1;
        if (axis_name.size() == 1) {
            char c = static_cast<char>(std::tolower(static_cast<unsigned char>(axis_name[0])));
            axis = c == 'x' ? 0 : c == 'y' ? 1 : c == 'z' ? 2 : -1;
        }
        if (axis < 0) fail("unknown axis '" + std::string(axis_name) + "' (use x, y or z)");
        if (seen[axis]) fail("axis '" + std::string(axis_name) + "' given twice");
        seen[axis] = true;
        float value = 0;
        scene_detail::NumberStatus status = scene_detail::parse_float(value_text, value);
        if (status != scene_detail::NumberStatus::ok)
            fail(std::string(scene_detail::describe(status)) + " '" + std::string(value_text) + "'");
        degrees[axis] = value;
        pos = comma + 1;
    }
    return degrees;
}

}  // namespace spacebvh::tools
