// Wide BVHs: any binary tree collapsed into 4- or 8-wide nodes, traversed one ray at a time with a
// SIMD test of all of a node's child boxes at once (the layout of Embree's BVH4/BVH8, after Wald,
// Benthin, Boulos 2008 and Dammertz et al. 2008), and leaves whose triangles are tested four at a time.
// Answers equal the binary tracer's: the same watertight test with the same exact fallback.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "spacebvh/tracer.hpp"

namespace spacebvh {

// The instructions that test a node's child boxes. Triangles are tested with SSE in every non-scalar
// kernel (four per test).
enum class NodeTest {
    best,    // the fastest this CPU has for the width
    scalar,  // plain C++ loops: the reference (also tests triangles one at a time)
    sse,     // 4 lanes (width 4)
    avx2,    // 8 lanes (width 8)
    avx512,  // AVX-512VL mask compares and compress-store of the hit children (width 4 and 8)
};
const char* to_string(NodeTest test);

// How a binary tree is collapsed into wide nodes.
enum class WideCollapse {
    // Ylitie, Karras, Laine 2017: the cheapest cut of the binary tree into wide nodes under a wide
    // SAH (a node test and a four-triangle pack test per box entered, at equal cost), found by
    // dynamic programming; small subtrees may become one leaf and nodes may keep fewer children.
    sah_optimal,
    // Embree's: from a node's two children, open the child of largest surface area until the node has
    // W children or only leaves.
    largest_area,
};
const char* to_string(WideCollapse collapse);  // "sah", "area"
// How make_tracer names mark a collapse: "" for sah_optimal (the default), "@area".
std::string collapse_suffix(WideCollapse collapse);
// The node tests available for `width` (4 or 8) on this CPU, "best" excluded, slowest first.
std::vector<NodeTest> supported_node_tests(int width);

class WideTracer final : public Tracer {
public:
    // Collapses `bvh` into `width`-wide nodes (4 or 8) by `collapse`. Throws Error for another width
    // or a node test this CPU or width lacks.
    WideTracer(const Scene& scene, const Bvh& bvh, int width, NodeTest test = NodeTest::best,
               WideCollapse collapse = WideCollapse::sah_optimal);
    ~WideTracer() override;
    WideTracer(WideTracer&&) noexcept;
    WideTracer& operator=(WideTracer&&) noexcept;

    Hit intersect(const Ray& ray) const override;
    Hit intersect(const Ray& ray, TraversalStats& stats) const override;
    bool occluded(const Ray& ray) const override;
    bool occluded(const Ray& ray, TraversalStats& stats) const override;
    void intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats = nullptr) const override;
    void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats = nullptr) const override;
    size_t memory_bytes() const override;
    std::string name() const override;  // e.g. "bvh8-avx512"

    int width() const;
    NodeTest node_test() const;
    size_t node_count() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace spacebvh
