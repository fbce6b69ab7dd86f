// SPDX-License-Identifier: MIT
// Instanced scenes: counts, flattening, the spec dispatch and the RenderScene built from a description
// (each mesh once, each nested scene object once).
#include "spacebvh/tools/instanced_scene.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>

#include "tools/scene/instanced_internal.hpp"
#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools {
namespace {

using scene_detail::Affine64;

std::string lower_extension(std::string_view spec) {
    std::string extension = std::filesystem::path(std::string(spec)).extension().string();
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return extension;
}

// Depth-first over the levels with a guard on nesting: a description is plain data, so a caller could
// build a nest deeper than RenderScene takes (or, through const_cast, a cycle).
template <typename Visit>
void walk_placements(const InstancedScene& scene, const Affine64& parent, uint32_t parent_mask, uint32_t level,
                     const Visit& visit) {
    if (level >= kMaxInstanceLevels)
        throw Error("instanced scene '" + scene.name + "': nested deeper than " + std::to_string(kMaxInstanceLevels) +
                    " levels");
    for (size_t i = 0; i < scene.instances.size(); ++i) {
        const SceneInstance& instance = scene.instances[i];
        const Affine64 composed = parent * Affine64(instance.transform);
        const uint32_t mask = parent_mask & instance.mask;
        if (instance.scene) {
            walk_placements(*instance.scene, composed, mask, level + 1, visit);
        } else {
            if (instance.mesh >= scene.meshes.size())
                throw Error("instanced scene '" + scene.name + "': instance " + std::to_string(i) + " names mesh " +
                            std::to_string(instance.mesh) + " of " + std::to_string(scene.meshes.size()));
            visit(scene, instance.mesh, composed, mask);
        }
    }
}

// The distinct scene objects below and including `scene`, each once, children first.
void collect_scenes(const InstancedScene& scene, uint32_t level, std::vector<const InstancedScene*>& out) {
    if (level >= kMaxInstanceLevels)
        throw Error("instanced scene '" + scene.name + "': nested deeper than " + std::to_string(kMaxInstanceLevels) +
                    " levels");
    for (const SceneInstance& instance : scene.instances)
        if (instance.scene && std::find(out.begin(), out.end(), instance.scene.get()) == out.end())
            collect_scenes(*instance.scene, level + 1, out);
    if (std::find(out.begin(), out.end(), &scene) == out.end()) out.push_back(&scene);
}

// The meshes of `scene` that some instance places, in mesh order.
std::vector<uint32_t> used_meshes(const InstancedScene& scene) {
    std::vector<char> used(scene.meshes.size(), 0);
    for (size_t i = 0; i < scene.instances.size(); ++i) {
        const SceneInstance& instance = scene.instances[i];
        if (instance.scene) continue;
        if (instance.mesh >= scene.meshes.size())
            throw Error("instanced scene '" + scene.name + "': instance " + std::to_string(i) + " names mesh " +
                        std::to_string(instance.mesh) + " of " + std::to_string(scene.meshes.size()));
        used[instance.mesh] = 1;
    }
    std::vector<uint32_t> out;
    for (uint32_t m = 0; m < used.size(); ++m)
        if (used[m]) out.push_back(m);
    return out;
}

}  // namespace

namespace scene_detail {

std::string invalid_instance_transform(const Affine& transform) {
    const auto& m = transform.m;
    for (int i = 0; i < 12; ++i)
        if (!std::isfinite(m[i]))
            return "has a NaN or infinite entry (row " + std::to_string(i / 4) + ", column " + std::to_string(i % 4) +
                   ")";
    const Affine64 a(transform);
    const double det = a.determinant();
    if (det == 0.0 || !std::isfinite(det)) return "is singular (determinant 0)";
    // ||A^-1|| from the adjugate: (A^-1)_ij = cofactor_ji / det.
    auto at = [&](int r, int c) { return a.m[4 * r + c]; };
    double norm = 0.0, inverse_norm = 0.0;
    for (int i = 0; i < 3; ++i) {
        norm = std::max(norm, std::fabs(at(i, 0)) + std::fabs(at(i, 1)) + std::fabs(at(i, 2)));
        double row = 0.0;
        for (int j = 0; j < 3; ++j) {
            const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
            row += std::fabs(at(r0, c0) * at(r1, c1) - at(r0, c1) * at(r1, c0));
        }
        inverse_norm = std::max(inverse_norm, row / std::fabs(det));
    }
    const double condition = norm * inverse_norm;
    if (!(condition <= 65536.0))
        return "is nearly singular (condition number " + std::to_string(condition) + ", above 65536)";
    return "";
}

}  // namespace scene_detail

uint32_t InstancedScene::depth() const {
    uint32_t deepest = 0;
    for (const SceneInstance& instance : instances)
        deepest = std::max(deepest, instance.scene ? instance.scene->depth() : 0u);
    return instances.empty() ? 0 : deepest + 1;
}

uint64_t InstancedScene::unique_triangle_count() const {
    std::vector<const InstancedScene*> scenes;
    collect_scenes(*this, 0, scenes);
    uint64_t total = 0;
    for (const InstancedScene* scene : scenes)
        for (const Scene& mesh : scene->meshes) total += mesh.triangles.size();
    return total;
}

uint64_t InstancedScene::instanced_triangle_count() const {
    uint64_t total = 0;
    walk_placements(*this, Affine64{}, ~0u, 0, [&](const InstancedScene& s, uint32_t mesh, const Affine64&, uint32_t) {
        total += s.meshes[mesh].triangles.size();
    });
    return total;
}

uint64_t InstancedScene::placement_count() const {
    uint64_t total = 0;
    walk_placements(*this, Affine64{}, ~0u, 0,
                    [&](const InstancedScene&, uint32_t, const Affine64&, uint32_t) { ++total; });
    return total;
}

std::vector<FlatPlacement> flatten_placements(const InstancedScene& scene, uint64_t max_placements) {
    std::vector<FlatPlacement> out;
    walk_placements(scene, Affine64{}, ~0u, 0,
                    [&](const InstancedScene& s, uint32_t mesh, const Affine64& transform, uint32_t mask) {
                        if (out.size() >= max_placements)
                            throw Error("instanced scene '" + scene.name + "': more than " +
                                        std::to_string(max_placements) + " placements to flatten");
                        out.push_back({&s, mesh, transform.rounded(), mask});
                    });
    return out;
}

Scene flatten_scene(const InstancedScene& scene, uint64_t max_triangles) {
    const uint64_t count = scene.instanced_triangle_count();
    if (count > max_triangles)
        throw Error("instanced scene '" + scene.name + "': " + std::to_string(count) +
                    " instanced triangles, more than the " + std::to_string(max_triangles) +
                    " a flattened copy may hold");
    Scene flat;
    flat.name = scene.name + "@flattened";
    flat.triangles.reserve(count);
    for (const FlatPlacement& p : flatten_placements(scene))
        for (const Triangle& t : p.scene->meshes[p.mesh].triangles)
            flat.triangles.push_back({p.transform.apply(t.v0), p.transform.apply(t.v1), p.transform.apply(t.v2)});
    flat.degenerate_count = scene_detail::count_degenerate(flat.triangles);
    return flat;
}

bool is_instanced_scene_spec(std::string_view spec) {
    if (spec.starts_with(scene_detail::kForestPrefix) || spec == "builtin:forest") return true;
    if (spec.starts_with("builtin:")) return false;
    const std::string extension = lower_extension(spec);
    return extension == ".gltf" || extension == ".glb";
}

InstancedScene load_instanced_scene(std::string_view spec, const SceneTransform& transform) {
    if (const char* reason = transform.invalid_reason()) throw Error(std::string("scene transform: ") + reason);
    InstancedScene scene;
    if (spec.starts_with(scene_detail::kForestPrefix) || spec == "builtin:forest") {
        const size_t prefix = std::min(spec.size(), scene_detail::kForestPrefix.size());
        scene = scene_detail::make_forest(scene_detail::parse_forest_size(spec.substr(prefix)));
    } else if (is_instanced_scene_spec(spec)) {
        scene = scene_detail::load_gltf_instanced(std::string(spec));
    } else {
        // One mesh, loaded with the transform itself (as load_scene names and transforms it).
        scene.meshes.push_back(load_scene(std::string(spec), transform));
        scene.name = scene.meshes.back().name;
        scene.instances.push_back(SceneInstance{});
        return scene;
    }
    if (!transform.is_identity()) {
        const Affine64 outer = Affine64::from_transform(transform);
        for (SceneInstance& instance : scene.instances)
            instance.transform = (outer * Affine64(instance.transform)).rounded();
        scene.name += "@transformed";
    }
    return scene;
}

std::shared_ptr<RenderScene> make_render_scene(const InstancedScene& scene, const SceneConfig& config) {
    std::vector<const InstancedScene*> order;
    collect_scenes(scene, 0, order);
    check_memory_estimate("instanced scene '" + scene.name + "' (" + std::to_string(scene.placement_count()) +
                              " placements of " + std::to_string(scene.unique_triangle_count()) + " triangles)",
                          estimate_scene_memory(scene, config).total(), config.recipe.limits.memory_limit_bytes);
    std::map<const InstancedScene*, std::shared_ptr<RenderScene>> built;
    for (const InstancedScene* level : order) {
        std::vector<std::shared_ptr<RenderScene>> meshes(level->meshes.size());
        for (uint32_t m : used_meshes(*level)) {
            const Scene& mesh = level->meshes[m];
            meshes[m] = std::make_shared<RenderScene>(config, mesh.name);
            meshes[m]->attach_mesh(mesh.mesh());
            meshes[m]->commit();
        }
        auto top = std::make_shared<RenderScene>(config, level->name);
        for (const SceneInstance& instance : level->instances)
            top->attach_instance(instance.scene ? built.at(instance.scene.get()) : meshes[instance.mesh],
                                 instance.transform, instance.mask);
        top->commit();
        built[level] = std::move(top);
    }
    return built.at(&scene);
}

std::shared_ptr<RenderScene> make_render_scene(std::shared_ptr<const InstancedScene> scene, const SceneConfig& config) {
    if (!scene) throw Error("make_render_scene: no scene");
    struct Holder {
        std::shared_ptr<const InstancedScene> description;
        std::shared_ptr<RenderScene> render;
    };
    auto holder = std::make_shared<Holder>();
    holder->render = make_render_scene(*scene, config);
    holder->description = std::move(scene);
    RenderScene* render = holder->render.get();
    return std::shared_ptr<RenderScene>(std::move(holder), render);
}

SceneMemoryEstimate estimate_scene_memory(const InstancedScene& scene, const SceneConfig& config) {
    std::vector<const InstancedScene*> order;
    collect_scenes(scene, 0, order);
    std::vector<uint64_t> meshes;
    uint64_t instances = 0, top_levels = 0;
    for (const InstancedScene* level : order) {
        for (uint32_t m : used_meshes(*level)) meshes.push_back(level->meshes[m].triangles.size());
        instances += level->instances.size();
        ++top_levels;
    }
    return estimate_scene_memory(meshes, instances, top_levels + meshes.size(), config);
}

}  // namespace spacebvh::tools
