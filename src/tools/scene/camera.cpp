// SPDX-License-Identifier: MIT
// Cameras: parsing, the default camera of docs/rays.md and the camera table of a scene collection's MANIFEST.md.
#include <filesystem>
#include <fstream>

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools {
namespace {

constexpr std::string_view kBuiltinPrefix = "builtin:";

Camera transformed(const Camera& camera, const SceneTransform& transform) {
    if (transform.is_identity()) return camera;
    SceneTransform rotation_only;
    rotation_only.rotate_degrees = transform.rotate_degrees;
    Camera result = camera;
    result.eye = transform.apply(camera.eye);
    result.target = transform.apply(camera.target);
    result.up = rotation_only.apply(camera.up);
    return result;
}

}  // namespace

Camera Camera::parse(const std::string& text) {
    constexpr const char* kFormat = "ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy";
    std::vector<float> values;
    size_t pos = 0;
    while (pos <= text.size()) {
        size_t comma = text.find(',', pos);
        if (comma == std::string::npos) comma = text.size();
        std::string_view item = std::string_view(text).substr(pos, comma - pos);
        while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
        while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
        float value = 0;
        scene_detail::NumberStatus status = scene_detail::parse_float(item, value);
        if (status != scene_detail::NumberStatus::ok)
            throw Error("bad camera '" + text + "' (expected " + kFormat + "): item " +
                        std::to_string(values.size() + 1) + " " + scene_detail::quote_token(item) + " is a " +
                        scene_detail::describe(status));
        values.push_back(value);
        pos = comma + 1;
    }
    if (values.size() != 10)
        throw Error("bad camera '" + text + "': expected 10 comma-separated numbers (" + kFormat + "), got " +
                    std::to_string(values.size()));
    Camera camera;
    camera.eye = {values[0], values[1], values[2]};
    camera.target = {values[3], values[4], values[5]};
    camera.up = {values[6], values[7], values[8]};
    camera.fovy_degrees = values[9];
    if (!(camera.fovy_degrees > 0.0f && camera.fovy_degrees < 180.0f))
        throw Error("bad camera '" + text + "': fovy must be in (0, 180) degrees");
    if (camera.eye == camera.target) throw Error("bad camera '" + text + "': eye and target coincide");
    if (cross(camera.target - camera.eye, camera.up) == Vec3(0.0f))
        throw Error("bad camera '" + text + "': up is zero or parallel to the viewing direction");
    return camera;
}

Camera default_camera(const Scene& scene) {
    AABB box = scene.bounds();
    if (box.is_empty()) throw Error("scene '" + scene.name + "' is empty: no default camera");
    // Spelled out with explicit float rounding (see unfused) so the eye is bit-exact with the spec.
    using scene_detail::unfused;
    const Vec3 center = box.center();
    const Vec3 extent = box.extent();
    const float diagonal =
        std::sqrt((unfused(extent.x * extent.x) + unfused(extent.y * extent.y)) + unfused(extent.z * extent.z));
    const float direction_length = std::sqrt((unfused(1.0f * 1.0f) + unfused(0.6f * 0.6f)) + unfused(1.0f * 1.0f));
    const Vec3 direction = Vec3(1.0f, 0.6f, 1.0f) / direction_length;
    const float distance = 1.5f * diagonal;
    const Vec3 offset{unfused(direction.x * distance), unfused(direction.y * distance),
                      unfused(direction.z * distance)};
    Camera camera;
    camera.eye = center + offset;
    camera.target = center;
    camera.up = Vec3(0.0f, 1.0f, 0.0f);
    camera.fovy_degrees = 45.0f;
    return camera;
}

std::optional<Camera> manifest_camera(const std::string& manifest, const std::string& stem) {
    std::ifstream in(manifest);
    if (!in) throw Error("cannot read the scene manifest '" + manifest + "'");
    std::string line;
    size_t line_number = 0;
    while (std::getline(in, line)) {
        ++line_number;
        // Rows look like: | bunny | `-0.016,0.11,0.25,-0.016,0.11,0,0,1,0,45` |
        if (line.empty() || line[0] != '|') continue;
        size_t name_end = line.find('|', 1);
        if (name_end == std::string::npos) continue;
        std::string name = line.substr(1, name_end - 1);
        while (!name.empty() && name.front() == ' ') name.erase(name.begin());
        while (!name.empty() && name.back() == ' ') name.pop_back();
        if (name != stem) continue;
        size_t open = line.find('`', name_end);
        size_t close = open == std::string::npos ? open : line.find('`', open + 1);
        size_t cell_end = line.find('|', name_end + 1);
        // Only the two-column camera table has the camera in the cell right after the name.
        if (open == std::string::npos || close == std::string::npos || open > cell_end) continue;
        std::string text = line.substr(open + 1, close - open - 1);
        try {
            return Camera::parse(text);
        } catch (const Error& e) {
            throw Error(manifest + ":" + std::to_string(line_number) + ": " + e.what());
        }
    }
    return std::nullopt;
}

Camera camera_for_scene(const Scene& scene, const std::string& source, const SceneTransform& transform,
                        const std::string& manifest) {
    if (source.rfind(kBuiltinPrefix, 0) == 0) {
        if (auto camera = scene_detail::builtin_camera(source.substr(kBuiltinPrefix.size())))
            return transformed(*camera, transform);
        return default_camera(scene);
    }
    if (!manifest.empty()) {
        if (auto camera = manifest_camera(manifest, std::filesystem::path(source).stem().string()))
            return transformed(*camera, transform);
    }
    return default_camera(scene);
}

}  // namespace spacebvh::tools
