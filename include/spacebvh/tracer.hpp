// Single-ray traversal (closest hit and any hit): the interface every kernel offers, and the compact
// binary layout, the reference kernel. Wide SIMD kernels: wide_tracer.hpp; choosing one: make_tracer.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
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

// What every traversal kernel offers. Answers are exact (equal to the arbiter of
// ../shared/spec/rays.md) whatever the kernel; only speed and the work counted in TraversalStats differ.
class Tracer {
public:
    virtual ~Tracer() = default;

    virtual Hit intersect(const Ray& ray) const = 0;
    virtual Hit intersect(const Ray& ray, TraversalStats& stats) const = 0;
    virtual bool occluded(const Ray& ray) const = 0;
    virtual bool occluded(const Ray& ray, TraversalStats& stats) const = 0;

    // Batches across the calling thread's oneTBB arena. `stats`, when given, receives the totals.
    virtual void intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats = nullptr) const = 0;
    virtual void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats = nullptr) const = 0;

    virtual size_t memory_bytes() const = 0;  // nodes + leaf triangle data
    virtual std::string name() const = 0;     // the kernel, as make_tracer spells it
};

// Compact binary layout: each inner node stores both child boxes together (one fetch decides both),
// the nearer child is visited first, and leaves hold their triangles' vertices contiguously.
// Triangle tests are watertight (Woop, Benthin, Wald 2013) with an exact double-precision recheck
// near edges, so the answers equal the exact arbiter of ../shared/spec/rays.md.
// TraversalStats::nodes_visited counts child boxes tested (two per compact node).
class BinaryTracer final : public Tracer {
public:
    BinaryTracer(const Scene& scene, const Bvh& bvh);
    ~BinaryTracer() override;
    BinaryTracer(BinaryTracer&&) noexcept;
    BinaryTracer& operator=(BinaryTracer&&) noexcept;

    Hit intersect(const Ray& ray) const override;
    Hit intersect(const Ray& ray, TraversalStats& stats) const override;
    bool occluded(const Ray& ray) const override;
    bool occluded(const Ray& ray, TraversalStats& stats) const override;
    void intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats = nullptr) const override;
    void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats = nullptr) const override;
    size_t memory_bytes() const override;
    std::string name() const override { return "binary"; }

    struct Layout;

private:
    std::unique_ptr<Layout> layout_;
};

// The kernels by name: "binary" (the scalar reference); "bvh4", "bvh8" (wide nodes with the widest node
// test this CPU has) or "bvh4-NODETEST" / "bvh8-NODETEST" with NODETEST one of scalar, sse, avx2,
// avx512 (wide_tracer.hpp); packets of consecutive rays "packet8" / "packet16" (64 or 256 rays: 8x8 or
// 16x16 tiles when the rays are in tile_order; packet_tracer.hpp), also with "-NODETEST"; and "auto",
// the fastest single-ray kernel measured (bench/RESULTS.md). Wide kernels collapse the tree
// SAH-optimally; NAME@area collapses it as Embree does (WideCollapse). Throws Error for an unknown
// name or a node test this CPU or width lacks.
std::unique_ptr<Tracer> make_tracer(const std::string& kernel, const Scene& scene, const Bvh& bvh);
// The names make_tracer accepts on this CPU.
std::vector<std::string> kernel_names();

}  // namespace spacebvh
