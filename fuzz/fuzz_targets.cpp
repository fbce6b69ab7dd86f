// SPDX-License-Identifier: MIT
#include "fuzz_targets.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "builder_spec.hpp"
#include "tree_file/tree_file_checksum.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tree_file.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/scene_file.hpp"
#include "spacebvh/tools/instanced_scene.hpp"
#include "tools/scene/instanced_internal.hpp"
#include "tools/scene/scene_internal.hpp"

namespace spacebvh::fuzz {
namespace {

std::string_view as_text(std::span<const uint8_t> bytes) {
    return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

// The ray and hit readers' stream entry over the bytes themselves (no file system in the loop).
std::FILE* memory_stream(std::span<const uint8_t> bytes) {
    static const char kEmpty = 0;  // fmemopen wants a buffer even for 0 bytes
    void* buffer = bytes.empty() ? const_cast<char*>(&kEmpty) : static_cast<void*>(const_cast<uint8_t*>(bytes.data()));
    std::FILE* file = ::fmemopen(buffer, bytes.size(), "rb");
    if (file == nullptr) throw std::runtime_error("fuzz: fmemopen failed");
    return file;
}

// Rays through the geometry's box from a few directions, including axis-parallel ones (zero
// direction components) and some starting inside.
std::vector<Ray> probe_rays() {
    std::vector<Ray> rays;
    for (int i = 0; i < 64; ++i) {
        const float a = float(i % 8) / 7.0f, b = float(i / 8) / 7.0f;
        rays.push_back(Ray{{-1.0f + 6.0f * a, -1.0f + 6.0f * b, -5.0f}, {0.0f, 0.0f, 1.0f}});
        rays.push_back(Ray{{6.0f, 3.0f * a, 3.0f * b}, {-1.0f, 0.1f * a, -0.2f * b}});
        rays.push_back(Ray{{2.0f, 2.0f, 0.5f}, {a - 0.5f, b - 0.5f, 0.3f}});
    }
    return rays;
}

void trace_all(const Bvh& bvh) {
    const MeshView mesh(fuzz_geometry());
    const std::vector<Ray> rays = probe_rays();
    // The layouts a loaded tree is converted into: wide float nodes, the binary layout, packets, and
    // quantized nodes (whose encoder must cope with whatever boxes a file holds).
    TracerConfig quantized{Kernel::bvh8};
    quantized.node_format = NodeFormat::quantized;
    for (const TracerConfig& config :
         {TracerConfig{Kernel::automatic}, TracerConfig{Kernel::binary}, TracerConfig{Kernel::packet8}, quantized}) {
        const Tracer tracer(mesh, bvh, config);
        std::vector<Hit> hits(rays.size());
        tracer.intersect(rays, hits);
        std::vector<uint8_t> occluded(rays.size());
        tracer.occluded(rays, occluded);
        for (size_t i = 0; i < rays.size(); ++i)
            if (hits[i].is_hit() && hits[i].primitive >= fuzz_geometry().size())
                throw std::logic_error("fuzz: a loaded tree's hit names triangle " + std::to_string(hits[i].primitive));
    }
}

// Byte 0 is the mode (low bit: repair the file size field and the checksum, so that the checks behind
// the checksum are reached); the rest is the file. Shared by the tree_file and scene_file targets.
std::vector<std::byte> repaired_file(std::span<const uint8_t> bytes, size_t at_file_size, size_t header_size) {
    std::vector<std::byte> file(bytes.size() - 1);
    std::transform(bytes.begin() + 1, bytes.end(), file.begin(), [](uint8_t b) { return std::byte(b); });
    if ((bytes[0] & 1) != 0) {
        if (file.size() >= header_size) {
            const uint64_t size = file.size();
            for (int i = 0; i < 8; ++i) file[at_file_size + i] = std::byte(uint8_t(size >> (8 * i)));
        }
        if (file.size() >= 8) {
            const uint64_t sum = tree_file_detail::checksum(std::span(file).first(file.size() - 8));
            for (int i = 0; i < 8; ++i) file[file.size() - 8 + i] = std::byte(uint8_t(sum >> (8 * i)));
        }
    }
    return file;
}

void feed_tree_file(std::span<const uint8_t> bytes) {
    if (bytes.empty()) return;
    const std::vector<std::byte> file = repaired_file(bytes, 32, 96);
    TreeFileInfo info;
    const Bvh bvh = deserialize_bvh(file, fuzz_geometry(), "fuzz.sbvh", &info);
    trace_all(bvh);
}

// A scene file loaded and traced with and without a mask: the loaded meshes, transforms and top levels
// reach the walks. Hits must name a geometry the loaded scene reports.
void feed_scene_file(std::span<const uint8_t> bytes) {
    if (bytes.empty()) return;
    const std::vector<std::byte> file = repaired_file(bytes, 16, 40);
    SceneFileInfo info;
    const std::shared_ptr<RenderScene> scene = deserialize_render_scene(file, "fuzz.sbvh", {}, &info);
    const std::vector<Ray> rays = tools::generate_random_rays(scene->bounds(), 32, 1);
    std::vector<SceneHit> hits(rays.size());
    std::vector<uint8_t> occluded(rays.size());
    for (const uint32_t mask : {0xFFFFFFFFu, 0x5u}) {
        scene->intersect(rays, hits, TraceContext{mask});
        scene->occluded(rays, occluded, TraceContext{mask});
        for (size_t i = 0; i < rays.size(); ++i) {
            if (hits[i].is_hit() && hits[i].primitive >= info.triangle_count)
                throw std::logic_error("fuzz: a loaded scene's hit names triangle " +
                                       std::to_string(hits[i].primitive));
            if (hits[i].is_hit() != (occluded[i] != 0) && std::isinf(rays[i].tmax))
                throw std::logic_error("fuzz: a loaded scene's hit and occlusion answers differ");
        }
    }
}

// A glTF as an instanced scene, built (binned trees, so that a hostile file cannot ask for a slow
// build) and traced: the instances' transforms reach RenderScene's checks and the ray transform.
void feed_gltf_instances(std::span<const uint8_t> bytes) {
    const tools::InstancedScene scene = tools::scene_detail::parse_gltf_instanced(as_text(bytes), "fuzz.gltf");
    const std::shared_ptr<RenderScene> render = tools::make_render_scene(scene, SceneConfig{});
    const std::vector<Ray> rays = tools::generate_random_rays(render->bounds(), 32, 1);
    std::vector<SceneHit> hits(rays.size());
    render->intersect(rays, hits);
    for (const SceneHit& hit : hits)
        if (hit.is_hit() && (hit.instance[0] >= scene.instances.size() ||
                             hit.primitive >= scene.meshes[scene.instances[hit.instance[0]].mesh].triangles.size()))
            throw std::logic_error("fuzz: an instanced glTF's hit names instance " + std::to_string(hit.instance[0]));
}

// The row syntax and the settings' ranges only: building the tree a valid row asks for can take
// seconds by design (grid=64 with lookahead), which a fuzzer would report as a hang.
void feed_builder_spec(std::span<const uint8_t> bytes) {
    const cli::BuilderSpec spec = cli::parse_builder_spec(std::string(as_text(bytes)), cli::BuildCliOptions{});
    spec.options.validate();
}

}  // namespace

const std::vector<std::string>& target_names() {
    static const std::vector<std::string> names = {"obj",      "ply",       "gltf",       "gltf_instances", "ray_file",
                                                   "hit_file", "tree_file", "scene_file", "builder_spec"};
    return names;
}

void feed(std::string_view target, std::span<const uint8_t> bytes) {
    using namespace tools::scene_detail;
    if (target == "obj")
        parse_obj(as_text(bytes), "fuzz.obj");
    else if (target == "ply")
        parse_ply(as_text(bytes), "fuzz.ply");
    else if (target == "gltf")
        parse_gltf(as_text(bytes), "fuzz.gltf");
    else if (target == "gltf_instances")
        feed_gltf_instances(bytes);
    else if (target == "ray_file")
        tools::read_ray_file(memory_stream(bytes), "fuzz.rays");
    else if (target == "hit_file")
        tools::read_hit_file(memory_stream(bytes), "fuzz.hits");
    else if (target == "tree_file")
        feed_tree_file(bytes);
    else if (target == "scene_file")
        feed_scene_file(bytes);
    else if (target == "builder_spec")
        feed_builder_spec(bytes);
    else
        throw std::invalid_argument("fuzz: unknown target '" + std::string(target) + "'");
}

const std::vector<Triangle>& fuzz_geometry() {
    static const std::vector<Triangle> triangles = [] {
        std::vector<Triangle> t;
        // A 4 x 4 grid of quads at z = 0 (two triangles each) ...
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 4; ++x) {
                const float x0 = float(x), y0 = float(y);
                t.push_back({{x0, y0, 0}, {x0 + 1, y0, 0}, {x0 + 1, y0 + 1, 0}});
                t.push_back({{x0, y0, 0}, {x0 + 1, y0 + 1, 0}, {x0, y0 + 1, 0}});
            }
        // ... long slivers across it (spatial splits cut them), a tilted wall, and two degenerates.
        t.push_back({{-0.5f, 0.1f, 1}, {4.5f, 3.9f, 1.5f}, {4.5f, 4.0f, 1.5f}});
        t.push_back({{0.2f, 3.8f, 2}, {3.9f, 0.3f, 0.5f}, {4.0f, 0.2f, 0.6f}});
        t.push_back({{0, 0, 0}, {4, 0, 3}, {0, 4, 3}});
        t.push_back({{1, 1, 1}, {2, 2, 2}, {3, 3, 3}});
        t.push_back({{2, 1, 1}, {2, 1, 1}, {2, 1, 1}});
        return t;
    }();
    return triangles;
}

}  // namespace spacebvh::fuzz
