// SPDX-License-Identifier: MIT
// Tracing rays through a built tree: one tracer type over every kernel. Answers are exact (equal to
// the exact arbiter, docs/design.md "Triangles") whatever the kernel; kernels differ only in speed
// and in the work counted by TraversalStats.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/mesh.hpp"

namespace spacebvh {

struct Hit {
    float t = kInfinity;                 // +inf for a miss
    uint32_t primitive = kInvalidIndex;  // triangle id in mesh order; kInvalidIndex for a miss
    float u = 0.0f, v = 0.0f;            // barycentrics of v1 and v2

    bool is_hit() const { return primitive != kInvalidIndex; }
};

// Work done by one or many rays (the statistics mode).
struct TraversalStats {
    uint64_t nodes_visited = 0;     // child boxes tested
    uint64_t triangles_tested = 0;  // ray-triangle tests
    // Where the float leaf test could not decide a triangle alone (single-ray wide kernels): the
    // exact test settled its edges, or its distance was taken from the plane equation in double.
    uint64_t exact_tests = 0;
    uint64_t plane_distances = 0;
    TraversalStats& operator+=(const TraversalStats& o) {
        nodes_visited += o.nodes_visited;
        triangles_tested += o.triangles_tested;
        exact_tests += o.exact_tests;
        plane_distances += o.plane_distances;
        return *this;
    }
};

// The traversal kernels.
enum class Kernel {
    automatic,  // the fastest single-ray kernel on this machine (bvh8 with its widest node test)
    binary,     // compact binary nodes, both child boxes in one SSE test: the reference kernel
    bvh4,       // 4-wide nodes (Wald, Benthin, Boulos 2008; Dammertz et al. 2008)
    bvh8,       // 8-wide nodes
    packet8,    // packets of 64 consecutive rays (an 8x8 tile) over 8-wide nodes (Wald et al. 2007)
    packet16,   // packets of 256 consecutive rays (16x16)
};

// The instructions that test a wide node's child boxes. Triangles are tested four at a time with SSE
// in every non-scalar kernel.
enum class NodeTest {
    best,    // the fastest this CPU has for the width
    scalar,  // plain C++ loops: the reference (also tests triangles one at a time)
    sse,     // 4 lanes (width 4)
    avx2,    // 8 lanes (width 8)
    avx512,  // AVX-512VL mask compares and compress-store of the hit children (width 4 and 8)
};

// The leaf test of the single-ray wide kernels. Both give the exact arbiter's answers.
enum class LeafTest {
    // Woop, Benthin, Wald 2013 in float with an error bound, exact fallback (watertight_triangle.hpp).
    watertight,
    // Moller-Trumbore on precomputed normals with a static error bound on every decision, the same
    // exact fallback (moller_filter.hpp, docs/leaf-test.md); leaf data 224 bytes per four triangles
    // instead of 160.
    moller,
};

// How the single-ray 8-wide kernel stores its nodes. Both give the exact arbiter's answers.
enum class NodeFormat {
    full,  // float child boxes: 256 bytes per node (four cache lines)
    // Child boxes as 8-bit codes on a per-node grid, rounded outward (no box shrinks): 128 bytes per
    // node (two cache lines); decoding costs a convert and an fma per plane (kernel name "bvh8q").
    quantized,
};

// How a binary tree is collapsed into wide nodes.
enum class WideCollapse {
    // Ylitie, Karras, Laine 2017: the cheapest cut of the binary tree into wide nodes under a wide
    // SAH, found by dynamic programming; small subtrees may become one leaf.
    sah_optimal,
    // Embree's: from a node's two children, open the child of largest surface area until full.
    largest_area,
};

struct TracerConfig {
    Kernel kernel = Kernel::automatic;
    NodeTest node_test = NodeTest::best;                // wide and packet kernels
    WideCollapse collapse = WideCollapse::sah_optimal;  // wide and packet kernels
    uint32_t packet_size = 0;  // packet kernels: rays per packet, 1..256; 0 = the kernel's tile (64, 256)
    LeafTest leaf_test = LeafTest::watertight;  // bvh4 and bvh8 only
    NodeFormat node_format = NodeFormat::full;  // bvh8 only
    // bvh4 and bvh8 (full nodes): keep, per child slot, the binary node its box came from (4 bytes
    // a slot, counted in memory_bytes()), so that refit() updates the boxes in place; without it
    // refit() lays the tree out again. RenderScene keeps it for its meshes.
    bool keep_refit_map = false;
};

const char* to_string(Kernel kernel);          // "bvh8"
const char* to_string(NodeTest test);          // "avx2"
const char* to_string(WideCollapse collapse);  // "sah", "area"
const char* to_string(LeafTest leaf_test);     // "watertight", "moller"
const char* to_string(NodeFormat format);      // "full", "quantized"
// The node tests available for `width` (4 or 8) on this CPU, "best" excluded, slowest first.
std::vector<NodeTest> supported_node_tests(int width);

class Tracer {
public:
    // Lays the tree and the mesh's triangles out for the kernel (the tracer keeps its own copy of the
    // triangles; mesh and bvh may go afterwards). Throws Error for a node test this CPU or kernel
    // lacks, or a tree that does not belong to the mesh (a triangle id out of range).
    Tracer(const MeshView& mesh, const Bvh& bvh, Kernel kernel = Kernel::automatic);
    Tracer(const MeshView& mesh, const Bvh& bvh, const TracerConfig& config);
    ~Tracer();
    Tracer(Tracer&&) noexcept;
    Tracer& operator=(Tracer&&) noexcept;

    // Closest hit and any hit (occlusion) of one ray, for t in [ray.tmin, ray.tmax].
    Hit intersect(const Ray& ray) const;
    Hit intersect(const Ray& ray, TraversalStats& stats) const;
    bool occluded(const Ray& ray) const;
    bool occluded(const Ray& ray, TraversalStats& stats) const;

    // Batches across the calling thread's oneTBB arena; packet kernels trace consecutive rays
    // together (put the rays of an image tile next to each other: tile_order). `stats`, when given,
    // receives the totals.
    void intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats = nullptr) const;
    void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats = nullptr) const;

    // After the mesh's vertices moved (same triangles, same count) and `bvh`, the tree this tracer was
    // made from, had its boxes recomputed for them (same topology): the 4- and 8-wide layouts with float
    // nodes made with TracerConfig::keep_refit_map are updated in place (vertices and boxes read again, nodes and leaf
    // packing kept), the others made again from `bvh`, as is any layout where a triangle became or stopped being
    // degenerate. Answers are then exact for the moved mesh. Returns whether it was done in place.
    // Throws Error as the constructor does for a tree that does not belong to the mesh.
    bool refit(const MeshView& mesh, const Bvh& bvh);

    size_t memory_bytes() const;  // nodes + leaf triangle data
    size_t node_count() const;    // nodes of the layout
    std::string name() const;  // the kernel as the registry spells it: "bvh8-avx2", "bvh8-avx2+moller", "bvh8q-avx2",
                               // "packet8-avx512@area"
    const TracerConfig& config() const;  // with node_test resolved

    struct Impl;

private:
    friend struct TracerInternals;  // scenes call the kernels and refit directly (src/trace/tracer_access.hpp)
    std::unique_ptr<Impl> impl_;
};

// The order that groups the rays of a row-major width x height image into tile x tile blocks, blocks
// row-major; edge blocks are smaller. order[k] is the index of the k-th ray to trace.
std::vector<uint32_t> tile_order(uint32_t width, uint32_t height, uint32_t tile);

}  // namespace spacebvh
