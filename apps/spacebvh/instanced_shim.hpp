// SPDX-License-Identifier: MIT
// TEMPORARY stand-in for spacebvh/tools/instanced_scene.hpp (branch scene-inputs) until it is merged.
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "spacebvh/error.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::tools {

struct InstancedScene {
    std::string name;
    std::vector<Scene> meshes;
    struct Instance {
        uint32_t mesh;
        Affine transform;
        uint32_t mask = 0xFFFFFFFFu;
    };
    std::vector<Instance> instances;
};

inline bool is_instanced_scene_spec(std::string_view spec) { return spec.starts_with("builtin:forest:"); }

inline InstancedScene load_instanced_scene(std::string_view spec) {
    const std::string text(spec.substr(15));
    char* end = nullptr;
    const double n = std::strtod(text.c_str(), &end);
    if (text.empty() || *end || !(n >= 1 && n <= 1e6) || n != std::floor(n))
        throw Error("builtin:forest:N: N must be a whole number in [1, 1e6], not '" + text + "'");
    InstancedScene s;
    s.name = "forest-" + text;
    for (const char* name : {"organic", "soup"}) {
        Scene mesh = load_scene(std::string("builtin:") + name);
        mesh.triangles.resize(std::min<size_t>(mesh.triangles.size(), 3000));
        s.meshes.push_back(std::move(mesh));
    }
    const size_t count = size_t(n), side = size_t(std::ceil(std::sqrt(double(count))));
    for (size_t k = 0; k < count; ++k) {
        const double angle = 0.7 * double(k), c = std::cos(angle), si = std::sin(angle);
        const double scale[3] = {0.5 + 0.1 * double(k % 7), 1.0, 0.8 + 0.05 * double(k % 5)};
        Affine a;
        const double r[3][3] = {{c, 0, si}, {0, 1, 0}, {-si, 0, c}};
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) a.m[4 * i + j] = float(scale[i] * r[i][j] * (k % 3 == 0 && j == 0 ? -1 : 1));
        a.m[3] = float(k % side) * 3.0f;
        a.m[11] = float(k / side) * 3.0f;
        s.instances.push_back({uint32_t(k % 2), a});
    }
    return s;
}

inline std::shared_ptr<RenderScene> make_render_scene(const InstancedScene& s, const SceneConfig& config) {
    std::vector<std::shared_ptr<RenderScene>> leaves;
    for (const Scene& mesh : s.meshes) {
        leaves.push_back(std::make_shared<RenderScene>(config, mesh.name));
        leaves.back()->attach_mesh(mesh.mesh());
        leaves.back()->commit();
    }
    auto top = std::make_shared<RenderScene>(config, s.name);
    for (const auto& instance : s.instances)
        top->attach_instance(leaves[instance.mesh], instance.transform, instance.mask);
    top->commit();
    return top;
}

}  // namespace spacebvh::tools
