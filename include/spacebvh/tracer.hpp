// Single-ray traversal (closest hit and any hit) over a compact binary layout of a Bvh.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/scene.hpp"

namespace spacebvh {

struct Hit {
    float t = kInfinity;                 // +inf for a miss
    uint32_t primitive = kInvalidIndex;  // triangle id in file order; kInvalidIndex for a miss
    float u = 0.0f, v = 0.0f;            // barycentrics of v1 and v2

    bool is_hit() const { return primitive != kInvalidIndex; }
};

// Work done by one or many rays (the statistics mode).
struct TraversalStats {
    uint64_t nodes_visited = 0;     // boxes tested
    uint64_t triangles_tested = 0;  // ray-triangle tests
    TraversalStats& operator+=(const TraversalStats& o) {
        nodes_visited += o.nodes_visited;
        triangles_tested += o.triangles_tested;
        return *this;
    }
};

// Compact binary layout: each inner node stores both child boxes together (one fetch decides both),
// the nearer child is visited first, and leaves hold their triangles' vertices contiguously.
// Triangle tests are watertight (Woop, Benthin, Wald 2013) with an exact double-precision recheck
// near edges, so the answers equal the exact arbiter of ../shared/spec/rays.md.
class BinaryTracer {
public:
    BinaryTracer(const Scene& scene, const Bvh& bvh);
    ~BinaryTracer();
    BinaryTracer(BinaryTracer&&) noexcept;
    BinaryTracer& operator=(BinaryTracer&&) noexcept;

    Hit intersect(const Ray& ray) const;
    Hit intersect(const Ray& ray, TraversalStats& stats) const;
    bool occluded(const Ray& ray) const;
    bool occluded(const Ray& ray, TraversalStats& stats) const;

    // Batches across the calling thread's oneTBB arena. `stats`, when given, receives the totals.
    void intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats = nullptr) const;
    void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats = nullptr) const;

    size_t memory_bytes() const;  // nodes + leaf triangle data

    struct Layout;

private:
    std::unique_ptr<Layout> layout_;
};

}  // namespace spacebvh
