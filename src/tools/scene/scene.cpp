// SPDX-License-Identifier: MIT
// load_scene: picks the reader by extension (or builtin:NAME), applies the load transform, counts
// degenerate triangles and names the scene.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <string>

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools {
namespace {

constexpr std::string_view kBuiltinPrefix = "builtin:";

std::string format_number(float value) {
    char buffer[32];
    auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);  // shortest round-trip form
    return std::string(buffer, end);
}

// "@x:45,y:45,z:45", plus ",s:2" and ",t:(1,2,3)" when scaled or translated; "" for the identity.
std::string transform_suffix(const SceneTransform& transform) {
    if (transform.is_identity()) return "";
    std::string parts;
    auto add = [&](const std::string& part) { parts += (parts.empty() ? "" : ",") + part; };
    const char* axes[3] = {"x:", "y:", "z:"};
    for (int axis = 0; axis < 3; ++axis)
        if (transform.rotate_degrees[axis] != 0.0f) add(axes[axis] + format_number(transform.rotate_degrees[axis]));
    if (transform.scale != 1.0f) add("s:" + format_number(transform.scale));
    if (transform.translate != Vec3(0.0f))
        add("t:(" + format_number(transform.translate.x) + "," + format_number(transform.translate.y) + "," +
            format_number(transform.translate.z) + ")");
    return "@" + parts;
}

void check_transform(const SceneTransform& transform) {
    if (!is_finite(transform.rotate_degrees) || !is_finite(transform.translate) || !std::isfinite(transform.scale))
        throw Error("scene transform has a NaN or infinite component");
    if (transform.scale == 0.0f) throw Error("scene transform scale is 0");
}

}  // namespace

namespace scene_detail {

size_t count_degenerate(const std::vector<Triangle>& triangles) {
    return static_cast<size_t>(
        std::count_if(triangles.begin(), triangles.end(), [](const Triangle& t) { return t.is_degenerate(); }));
}

}  // namespace scene_detail

Scene load_scene(const std::string& source, const SceneTransform& transform) {
    check_transform(transform);
    Scene scene;
    if (source.rfind(kBuiltinPrefix, 0) == 0) {
        scene = make_builtin_scene(source.substr(kBuiltinPrefix.size()));
    } else {
        std::filesystem::path path(source);
        std::string extension = path.extension().string();
        std::transform(extension.begin(), extension.end(), extension.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (extension == ".obj") {
            scene.triangles = scene_detail::load_obj(source);
        } else if (extension == ".ply") {
            scene.triangles = scene_detail::load_ply(source);
        } else if (extension == ".gltf" || extension == ".glb") {
            scene.triangles = scene_detail::load_gltf(source);
        } else {
            throw Error("unknown scene format '" + extension + "' of '" + source +
                        "' (expected .obj, .ply, .gltf, .glb or builtin:NAME)");
        }
        scene.name = path.stem().string();
    }

    if (!transform.is_identity()) {
        const scene_detail::TransformMatrix matrix(transform);
        for (Triangle& triangle : scene.triangles) {
            triangle.v0 = matrix.apply(triangle.v0);
            triangle.v1 = matrix.apply(triangle.v1);
            triangle.v2 = matrix.apply(triangle.v2);
            if (!is_finite(triangle.v0) || !is_finite(triangle.v1) || !is_finite(triangle.v2))
                throw Error("scene '" + source + "': the load transform overflows float range");
        }
        scene.name += transform_suffix(transform);
    }
    // Counted after the transform: rounding can make a sliver exactly flat (or not).
    scene.degenerate_count = scene_detail::count_degenerate(scene.triangles);
    return scene;
}

Scene make_indexed_scene(std::span<const float> vertices, std::span<const int64_t> indices, const std::string& name) {
    const std::string what = "mesh '" + name + "'";
    if (vertices.size() % 3 != 0)
        throw Error(what + ": " + std::to_string(vertices.size()) + " vertex coordinates, not a multiple of 3");
    if (indices.size() % 3 != 0)
        throw Error(what + ": " + std::to_string(indices.size()) + " indices, not a multiple of 3");
    if (indices.empty()) throw Error(what + ": no triangles");
    const size_t vertex_count = vertices.size() / 3;
    for (size_t i = 0; i < vertices.size(); ++i)
        if (!std::isfinite(vertices[i]))
            throw Error(what + ": vertex " + std::to_string(i / 3) + " has a coordinate that is not finite");
    auto vertex = [&](size_t triangle, int corner) {
        const int64_t index = indices[3 * triangle + corner];
        if (index < 0 || uint64_t(index) >= vertex_count)
            throw Error(what + ": triangle " + std::to_string(triangle) + " uses vertex " + std::to_string(index) +
                        ", outside 0.." + std::to_string(int64_t(vertex_count) - 1));
        return Vec3{vertices[3 * index], vertices[3 * index + 1], vertices[3 * index + 2]};
    };
    Scene scene;
    scene.name = name;
    scene.triangles.reserve(indices.size() / 3);
    for (size_t t = 0; t < indices.size() / 3; ++t)
        scene.triangles.push_back({vertex(t, 0), vertex(t, 1), vertex(t, 2)});
    scene.degenerate_count = scene_detail::count_degenerate(scene.triangles);
    return scene;
}

}  // namespace spacebvh::tools
