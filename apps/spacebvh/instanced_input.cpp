// SPDX-License-Identifier: MIT
#include "instanced_input.hpp"

#include <cstdio>

#include "spacebvh/error.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "spacebvh/presets.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

namespace {

// The last description loaded: deciding whether a glTF instances its meshes loads it, and the command
// then uses it.
struct LoadedDescription {
    std::string source;
    SceneTransform transform;
    std::shared_ptr<const InstancedScene> scene;
};
LoadedDescription& last_loaded() {
    static LoadedDescription loaded;
    return loaded;
}

std::shared_ptr<const InstancedScene> load_description(const std::string& source, const SceneTransform& transform) {
    LoadedDescription& last = last_loaded();
    const SceneTransform& t = last.transform;
    if (last.scene && last.source == source && t.rotate_degrees == transform.rotate_degrees &&
        t.scale == transform.scale && t.translate == transform.translate)
        return last.scene;
    last = {source, transform, std::make_shared<const InstancedScene>(load_instanced_scene(source, transform))};
    return last.scene;
}

}  // namespace

bool names_instanced_scene(const std::string& source) {
    if (source.starts_with("builtin:forest:")) return true;
    if (!is_instanced_scene_spec(source)) return false;
    try {
        const std::shared_ptr<const InstancedScene> scene = load_description(source, SceneTransform{});
        return scene->depth() > 1 || scene->placement_count() > scene->meshes.size();
    } catch (const Error&) {
        return false;  // the one-mesh reader says what is wrong with it
    }
}

TracerConfig instanced_scene_kernel(const std::string& kernel) {
    const TracerConfig config = parse_kernel(kernel == "auto" ? "bvh8" : kernel);
    if (config.kernel == Kernel::packet8 || config.kernel == Kernel::packet16)
        throw Error("--kernel " + kernel +
                    ": packet kernels cannot trace instanced scenes (single-ray kernels only: binary, bvh4, bvh8; "
                    "docs/scenes.md)");
    return config;
}

size_t InstancedInput::KeyHash::operator()(const Key& key) const {
    uint64_t h = key.geometry;
    for (uint32_t id : key.path) h = (h ^ id) * 0x9E3779B97F4A7C15ull;
    return size_t(h ^ (h >> 29));
}

InstancedInput::InstancedInput(const std::string& source, const SceneTransform& transform) {
    description_ = load_description(source, transform);
    name_ = description_->name;
    ScenePlacements placed = mesh_placements_of(*description_);
    meshes_ = std::move(placed.meshes);
    arbiter_ = std::make_unique<SceneArbiter>(meshes_, std::move(placed.placements));
    const std::vector<MeshPlacement>& all = arbiter_->placements();
    placement_of_.reserve(all.size());
    for (size_t p = 0; p < all.size(); ++p) placement_of_.emplace(Key{all[p].path, all[p].geometry}, uint32_t(p));
}

size_t InstancedInput::instance_count() const { return description_->instances.size(); }

uint64_t InstancedInput::instanced_triangles() const { return description_->instanced_triangle_count(); }

uint64_t InstancedInput::memory_estimate(const TreeRecipe& recipe) const {
    return estimate_scene_memory(*description_, SceneConfig{recipe, TracerConfig{}}).total();
}

void InstancedInput::check_memory(const TreeRecipe& recipe) const { check_memory(std::span(&recipe, 1), 1); }

void InstancedInput::check_memory(std::span<const TreeRecipe> recipes, size_t copies) const {
    uint64_t estimate = 0;
    for (const TreeRecipe& recipe : recipes) estimate += copies * memory_estimate(recipe);
    const size_t scenes = recipes.size() * copies;
    std::printf("memory estimate  %s to build %s%s (each mesh's tree once, the instances, the top levels)\n",
                format_bytes(estimate).c_str(), name_.c_str(),
                scenes > 1 ? (" " + std::to_string(scenes) + " times, the rows' scenes").c_str() : "");
    std::fflush(stdout);
    check_memory_estimate("scene '" + name_ + "'", estimate, recipes.front().limits.memory_limit_bytes);
}

std::shared_ptr<RenderScene> InstancedInput::build(const SceneConfig& config) const {
    return make_render_scene(description_, config);
}

Camera InstancedInput::default_camera() const { return tools::default_camera(world_box()); }

Scene InstancedInput::world_box() const {
    Scene box;
    box.name = name_;
    box.triangles = {{bounds().lo, bounds().hi, bounds().lo}};
    box.degenerate_count = 1;
    return box;
}

Triangle InstancedInput::world_triangle(const SceneHit& hit) const {
    const auto found = placement_of_.find(Key{hit.instance, hit.geometry});
    if (found == placement_of_.end() || !hit.is_hit())
        throw Error("scene '" + name_ + "': a hit names geometry " + std::to_string(hit.geometry) +
                    " under an instance path the scene does not hold");
    const MeshPlacement& placement = placements()[found->second];
    const std::vector<Triangle>& triangles = meshes()[placement.mesh].triangles;
    if (hit.primitive >= triangles.size())
        throw Error("scene '" + name_ + "': a hit names triangle " + std::to_string(hit.primitive) + " of " +
                    std::to_string(triangles.size()));
    Triangle w = triangles[hit.primitive];
    for (size_t level = placement.transforms.size(); level-- > 0;) {
        const Affine& a = placement.transforms[level];
        w = {a.apply(w.v0), a.apply(w.v1), a.apply(w.v2)};
    }
    return w;
}

}  // namespace spacebvh::cli
