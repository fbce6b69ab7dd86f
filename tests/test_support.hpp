// Helpers shared by the test files: our answers as hit-file records, ready for verify_against_reference.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "build/reference.hpp"
#include "spacebvh/rays.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tracer.hpp"

namespace spacebvh::testing_support {

// `builtin:NAME`, loaded once per test process (thread-safe).
inline const Scene& cached_builtin_scene(const std::string& name) {
    static std::mutex mutex;
    static std::map<std::string, std::unique_ptr<Scene>> cache;
    std::lock_guard lock(mutex);
    auto& slot = cache[name];
    if (!slot) slot = std::make_unique<Scene>(load_scene("builtin:" + name));
    return *slot;
}

// Two unit squares at z = 0 (triangles 0, 1) and z = -1 (triangles 2, 3).
inline Scene two_floors() {
    Scene scene;
    scene.name = "two_floors";
    for (float z : {0.0f, -1.0f}) {
        scene.triangles.push_back({{0, 0, z}, {1, 0, z}, {1, 1, z}});
        scene.triangles.push_back({{0, 0, z}, {1, 1, z}, {0, 1, z}});
    }
    return scene;
}

// A node for testing split finders directly: its triangles, one reference per triangle (whole box),
// and their summary.
struct SmallNode {
    std::vector<Triangle> triangles;
    std::vector<build::Reference> references;
    build::ReferenceSummary summary;
};
inline SmallNode small_node(std::vector<Triangle> triangles) {
    SmallNode node;
    node.triangles = std::move(triangles);
    for (uint32_t i = 0; i < node.triangles.size(); ++i) node.references.push_back({node.triangles[i].bounds(), i});
    node.summary = build::summarize(node.references);
    return node;
}

inline std::vector<HitRecord> closest_records(const Tracer& tracer, std::span<const Ray> rays) {
    std::vector<Hit> hits(rays.size());
    tracer.intersect(rays, hits);
    std::vector<HitRecord> records(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) records[i] = to_record(hits[i]);
    return records;
}

inline std::vector<HitRecord> occlusion_records(const Tracer& tracer, std::span<const Ray> rays) {
    std::vector<uint8_t> occluded(rays.size());
    tracer.occluded(rays, occluded);
    std::vector<HitRecord> records(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) records[i] = occlusion_record(occluded[i]);
    return records;
}

}  // namespace spacebvh::testing_support
