// SPDX-License-Identifier: MIT
#include "instanced_input.hpp"

#include <cstdio>

#include "spacebvh/error.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "spacebvh/presets.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

namespace {

// Every placement of a mesh in the scene the description makes (make_render_scene: a scene per mesh
// holding it as geometry 0, instanced by the top scene in order, so instance k has id k).
std::vector<MeshPlacement> placements_of(const InstancedScene& scene) {
    std::vector<MeshPlacement> out(scene.instances.size());
    for (size_t k = 0; k < scene.instances.size(); ++k) {
        out[k].mesh = scene.instances[k].mesh;
        out[k].transforms = {scene.instances[k].transform};
        out[k].path[0] = uint32_t(k);
        out[k].geometry = 0;
        out[k].masks = {scene.instances[k].mask, 0xFFFFFFFFu};
    }
    return out;
}

size_t instance_count_of(const InstancedScene& scene) { return scene.instances.size(); }

uint64_t estimate_instanced_scene_memory(const InstancedScene& scene, const TreeRecipe& recipe) {
    uint64_t bytes = 0;
    for (const Scene& mesh : scene.meshes)
        bytes += estimate_build_memory(mesh.triangles.size(), recipe).bytes + 128 * mesh.triangles.size();
    return bytes + 512 * scene.instances.size();
}

}  // namespace

bool names_instanced_scene(const std::string& source) { return is_instanced_scene_spec(source); }

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
    if (!transform.is_identity())
        throw Error(source + ": --rotate, --scale and --translate transform one mesh; an instanced scene places its "
                             "meshes itself");
    description_ = load_instanced_scene(source);
    name_ = description_.name;
    arbiter_ = std::make_unique<SceneArbiter>(meshes(), placements_of(description_));
    const std::vector<MeshPlacement>& all = arbiter_->placements();
    placement_of_.reserve(all.size());
    for (size_t p = 0; p < all.size(); ++p) placement_of_.emplace(Key{all[p].path, all[p].geometry}, uint32_t(p));
}

const std::vector<Scene>& InstancedInput::meshes() const { return description_.meshes; }

size_t InstancedInput::instance_count() const { return instance_count_of(description_); }

uint64_t InstancedInput::instanced_triangles() const {
    uint64_t total = 0;
    for (const MeshPlacement& p : placements()) total += meshes()[p.mesh].triangles.size();
    return total;
}

uint64_t InstancedInput::memory_estimate(const TreeRecipe& recipe) const {
    return estimate_instanced_scene_memory(description_, recipe);
}

void InstancedInput::check_memory(const TreeRecipe& recipe) const {
    const uint64_t estimate = memory_estimate(recipe);
    std::printf("memory estimate  %s to build %s (each mesh's tree once, the instances, the top levels)\n",
                format_bytes(estimate).c_str(), name_.c_str());
    std::fflush(stdout);
    check_memory_estimate("scene '" + name_ + "'", estimate, recipe.limits.memory_limit_bytes);
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
