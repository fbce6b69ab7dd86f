// SPDX-License-Identifier: MIT
#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "trace/layout/binary_layout.hpp"
#include "trace/layout/huge_page_allocator.hpp"
#include "trace/traversal/traversal_common.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"
#include "trace/leaf_tests/watertight_triangle.hpp"
#include "trace/layout/wide_collapse.hpp"

namespace spacebvh::trace {

namespace {

// A push happens at most once per level, and build options cap the depth at 1024.
constexpr int kStackSize = 1024 + 8;
void set_child(CompactNode& node, int slot, const AABB& box, uint32_t child, uint32_t lanes) {
    if (lanes > CompactNode::kLanes)
        throw std::length_error("binary layout: a leaf of " + std::to_string(lanes) +
                                " triangles exceeds its 2^30 - 1 lanes");
    for (int axis = 0; axis < 3; ++axis) {
        node.planes[axis][slot] = box.lo[axis];
        node.planes[axis][slot + 2] = box.hi[axis];
    }
    node.child[slot] = child;
    node.word[slot] = lanes;
}

// Picks the node's order axis, the one along which its children's box centres lie farthest apart,
// and swaps the children so that child 0's centre is the lower. A ray going up that axis visits
// child 0 first. Choosing by the ray's direction sign, known as soon as the node is loaded, instead
// of by the entry distances, known only after the box test, makes a mispredicted choice cost far
// less, and it enters as many boxes (Sponza random rays: 42.0 per ray against 42.9).
void order_children(CompactNode& node) {
    auto centre_gap = [&](int axis) {
        return (node.planes[axis][1] + node.planes[axis][3]) - (node.planes[axis][0] + node.planes[axis][2]);
    };
    int axis = 0;
    for (int a = 1; a < 3; ++a)
        if (std::fabs(centre_gap(a)) > std::fabs(centre_gap(axis))) axis = a;
    if (centre_gap(axis) < 0.0f) {
        for (int a = 0; a < 3; ++a) {
            std::swap(node.planes[a][0], node.planes[a][1]);
            std::swap(node.planes[a][2], node.planes[a][3]);
        }
        std::swap(node.child[0], node.child[1]);
        std::swap(node.word[0], node.word[1]);
    }
    node.word[0] |= uint32_t(axis) << 30;
}

// Per-ray constants of the two-box slab test. kFused: per axis the fused slab constants (FusedSlabs,
// traversal_common.hpp) of the entry planes in lanes 0,1 and of the exit planes in lanes 2,3; used
// with FMA (native builds) for rays whose every axis has finite ones. Otherwise the origin and inverse
// direction, and the exit distance widened by kFarScale: portable builds (where a fused operation
// would be a slow library call), and rays with a direction component 0 (axis-aligned rays), along
// which (p - o) * (1/d) = +-inf still culls every box whose slab misses the origin while the fused
// constants of that axis would cull nothing.
template <bool kFused>
struct SlabRay {
    __m128 scale[3], offset[3];  // kFused
    __m128 org[3], inv_dir[3];   // !kFused
#ifdef __AVX__
    __m128i plane_order[3];  // lane permutation that puts the entry planes first (vpermilps)
#else
    bool negative[3];
#endif
    SlabRay(const Ray& ray, const FusedSlabs& slabs) {
        set_axis<0>(ray, slabs);
        set_axis<1>(ray, slabs);
        set_axis<2>(ray, slabs);
    }
    template <int kAxis>
    [[gnu::always_inline]] void set_axis(const Ray& ray, const FusedSlabs& slabs) {
        bool negative_direction;
        if constexpr (kFused) {
            // Lanes 0,1 from the entry constants' lane kAxis, lanes 2,3 from the exit constants'.
            constexpr int kAxisLanes = _MM_SHUFFLE(kAxis, kAxis, kAxis, kAxis);
            scale[kAxis] = _mm_shuffle_ps(slabs.entry_scale, slabs.exit_scale, kAxisLanes);
            offset[kAxis] = _mm_shuffle_ps(slabs.entry_offset, slabs.exit_offset, kAxisLanes);
            // The entry plane follows the sign of the fused scale, which differs from the direction's
            // where no axis has finite constants (FusedSlabs).
            negative_direction = (slabs.negative >> kAxis) & 1;
        } else {
            org[kAxis] = _mm_set1_ps(ray.org[kAxis]);
            inv_dir[kAxis] = _mm_set1_ps(1.0f / ray.dir[kAxis]);  // +-inf for axis-parallel rays
            negative_direction = std::signbit(ray.dir[kAxis]);    // the sign of inv_dir, -0 included
        }
#ifdef __AVX__
        plane_order[kAxis] = negative_direction ? _mm_setr_epi32(2, 3, 0, 1) : _mm_setr_epi32(0, 1, 2, 3);
#else
        negative[kAxis] = negative_direction;
#endif
    }

    // The slab distances of a node's two boxes on one axis: the entry planes' in lanes 0,1, the exit
    // planes' in lanes 2,3. The planes are reordered first: with AVX by a per-ray permutation, without
    // by a branch on the direction's sign (the same for the whole ray, so well predicted, but
    // mispredicted at many a ray's first nodes).
    [[gnu::always_inline]] __m128 distances(const float planes[4], int axis) const {
        __m128 ordered = _mm_load_ps(planes);
#ifdef __AVX__
        ordered = _mm_permutevar_ps(ordered, plane_order[axis]);
#else
        if (negative[axis]) ordered = _mm_shuffle_ps(ordered, ordered, _MM_SHUFFLE(1, 0, 3, 2));
#endif
        if constexpr (kFused) return fused_multiply_subtract(ordered, scale[axis], offset[axis]);
        return _mm_mul_ps(_mm_sub_ps(ordered, org[axis]), inv_dir[axis]);
    }

    // What the entry distances must not exceed, from the exit distances in lanes 0,1.
    [[gnu::always_inline]] __m128 exit_limit(__m128 exit, __m128 tmax) const {
        if constexpr (kFused) return exit;  // the exit distances started from tmax, and need no widening
        return _mm_min_ps(_mm_mul_ps(exit, _mm_set1_ps(kFarScale)), tmax);
    }
};

// Returns a 2-bit mask of the children whose boxes the ray enters within [tmin, tmax]; their entry
// distances go to `entry`. With FMA each slab distance is one fused multiply-subtract whose constants
// keep the test conservative (FusedSlabs), in place of (plane - o) * (1/d) and a widened exit: one
// rounding step less between a node's load and the choice of the next node (the same boxes entered,
// the same answers). A NaN or infinite distance (an
// axis the ray does not move along; 0 * inf where it lies in a slab plane) leaves the running bound
// unchanged, by the min/max operand order: boxes are closed.
template <bool kFused>
inline int intersect_children(const CompactNode& node, const SlabRay<kFused>& slab, __m128 tmin, __m128 tmax,
                              float entry[2]) {
    __m128 near = tmin;
    __m128 far = tmax;
    for (int axis = 0; axis < 3; ++axis) {
        const __m128 t = slab.distances(node.planes[axis], axis);
        near = _mm_max_ps(t, near);
        far = _mm_min_ps(t, far);
    }
    const __m128 limit = slab.exit_limit(_mm_movehl_ps(far, far), tmax);  // exit distances into lanes 0,1
    const int mask = _mm_movemask_ps(_mm_cmple_ps(near, limit)) & 3;
    _mm_storel_pi(reinterpret_cast<__m64*>(entry), near);
    return mask;
}

// A leaf's packs, out of line: inlined, the leaf test's many live values made the compiler spill and
// shuffle registers on every node visit, leaf or not (about 30 of the 130 instructions of a visit).
template <bool kAnyHit, bool kStats>
[[gnu::noinline]] bool test_leaf(const TrianglePack* packs, uint32_t first, uint32_t count, const Ray& ray,
                                 const WatertightRay& shear, const PackRay& pack_ray, float& tmax, Hit& hit,
                                 bool& found, TraversalStats* stats) {
    return test_leaf_packs<false, kAnyHit, kStats>(packs, first, count, ray, shear, pack_ray, tmax, hit, found, stats);
}

// Closest hit (kAnyHit = false) or any hit. Leaf children are tested as soon as the ray enters them;
// of two inner children the one first along the ray's direction on the node's order axis is visited
// first (the other for any hit). Stack entries keep their entry distance, so a subtree entered
// beyond the closest hit found since it was pushed is skipped without fetching it.
template <bool kAnyHit, bool kStats, bool kFused>
bool walk(const BinaryLayout& layout, const Ray& ray, const FusedSlabs& slabs, Hit& hit, TraversalStats* stats) {
    const SlabRay<kFused> slab(ray, slabs);
    const WatertightRay shear(ray);
    const PackRay pack_ray(shear);
    const char* base = reinterpret_cast<const char*>(layout.buffer.data());
    auto at = [base](uint32_t child) { return base + size_t(child) * kUnit; };
    const __m128 tmin4 = _mm_set1_ps(ray.tmin);
    // Bit k: the ray goes down axis k, so its child 1 comes first along it.
    const unsigned goes_down = (std::signbit(ray.dir[0]) ? 1u : 0u) | (std::signbit(ray.dir[1]) ? 2u : 0u) |
                               (std::signbit(ray.dir[2]) ? 4u : 0u);
    float tmax = ray.tmax;
    bool found = false;

    struct Entry {
        uint32_t node;
        float entry;
    };
    Entry stack[kStackSize];
    int top = 0;
    uint32_t node_index = 0;

    while (true) {
        const CompactNode& node = *reinterpret_cast<const CompactNode*>(at(node_index));
        // The walk is bound by memory latency: start fetching both children (node or leaf triangles)
        // now, so the fetch overlaps this node's box tests. Two lines each: an inner child's first
        // inner child is laid out right after it, so the second line saves a wait one level further
        // down (a third line costs more than it saves), and for a leaf they hold most
        // of its first pack.
        for (int slot = 0; slot < 2; ++slot) {
            const char* child = at(node.child[slot]);
            _mm_prefetch(child, _MM_HINT_T0);
            _mm_prefetch(child + 64, _MM_HINT_T0);
        }
        if constexpr (kStats) stats->nodes_visited += 2;
        float entry[2];
        const int mask = intersect_children(node, slab, tmin4, _mm_set1_ps(tmax), entry);

        // Entered leaves are tested at once, in slot order; then the entered inner children decide
        // where to go next. Every such choice is a branch, never a select: a predicted branch lets
        // the next node's fetch start while this node's box test is still in flight, where a select
        // (or an index computed from the mask) makes that address wait for the test, which costs far
        // more than the occasional misprediction.
        const unsigned leaves = (node.lanes(0) != 0 ? 1u : 0u) | (node.lanes(1) != 0 ? 2u : 0u);
        const unsigned entered_leaves = unsigned(mask) & leaves;
        if (entered_leaves) [[unlikely]] {
            for (int slot = 0; slot < 2; ++slot)
                if (entered_leaves & (1u << slot))
                    if (test_leaf<kAnyHit, kStats>(reinterpret_cast<const TrianglePack*>(at(node.child[slot])), 0,
                                                   node.lanes(slot), ray, shear, pack_ray, tmax, hit, found, stats))
                        return true;
        }
        const unsigned inner = unsigned(mask) & ~leaves;
        if (inner == 3) {
            // A branch (see above), on a condition known before the box test is done.
            if (((goes_down >> node.order_axis()) & 1u) != unsigned(kAnyHit)) {
                stack[top++] = {node.child[0], entry[0]};
                node_index = node.child[1];
            } else {
                stack[top++] = {node.child[1], entry[1]};
                node_index = node.child[0];
            }
            continue;
        }
        if (inner == 1) {
            if (entry[0] <= tmax) {
                node_index = node.child[0];
                continue;
            }
        } else if (inner == 2) {
            if (entry[1] <= tmax) {
                node_index = node.child[1];
                continue;
            }
        }
        // Pop the nearest pending subtree that may still hold a closer hit.
        do {
            if (top == 0) return found;
            --top;
        } while (!kAnyHit && stack[top].entry > tmax);
        node_index = stack[top].node;
    }
}

// The fused box test for rays whose every axis has finite fused constants, with FMA; the
// subtract-multiply one otherwise (SlabRay).
template <bool kAnyHit, bool kStats>
bool traverse(const BinaryLayout& layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
    const FusedSlabs slabs(ray);
#ifdef __FMA__
    if (slabs.finite_axes == 7) [[likely]]
        return walk<kAnyHit, kStats, true>(layout, ray, slabs, hit, stats);
#endif
    return walk<kAnyHit, kStats, false>(layout, ray, slabs, hit, stats);
}

}  // namespace

namespace {

// The layout's two parts before they are joined: nodes with child indices into `nodes` (inner) or
// `packs` (leaf).
struct LayoutParts {
    std::vector<CompactNode> nodes;
    TrianglePacks packs;
};

LayoutParts lay_out(std::span<const Triangle> triangles, const Bvh& bvh) {
    LayoutParts layout;
    if (bvh.empty()) {
        // Nothing to hit: one node whose two children are empty boxes.
        layout.nodes.resize(1);
        set_child(layout.nodes[0], 0, AABB::empty(), 0, 0);
        set_child(layout.nodes[0], 1, AABB::empty(), 0, 0);
        return layout;
    }
    // Depth-first order: a node's left inner child directly follows it, so a descent tends to stay
    // within neighbouring cache lines. `pending` holds inner BVH nodes whose compact node is not made
    // yet, with the place (compact node, slot) that must point at it.
    struct Pending {
        uint32_t bvh_index, parent, slot;
    };
    std::vector<Pending> pending;
    LeafPacker packer(triangles, bvh, layout.packs);
    // A small subtree whose triangles fit a pack or two costs less as one leaf: one pack test
    // instead of a node visit and a test per leaf below it. The binary case of the wide layouts'
    // SAH-optimal collapse decides which (wide_collapse.hpp).
    const CollapsePlan plan(triangles, bvh, 2, WideCollapse::sah_optimal);
    auto set_from = [&](uint32_t compact, int slot, CollapseSlot from) {
        const BvhNode& child = bvh.nodes[from.node];
        if (from.leaf) {
            auto [first, count] =
                child.is_leaf() ? packer.add(child) : packer.add(subtree_triangles(triangles, bvh, from.node));
            // A leaf of degenerate triangles only can never be hit: give it an empty box.
            set_child(layout.nodes[compact], slot, count ? child.bounds : AABB::empty(), count ? first : 0, count);
        } else {
            set_child(layout.nodes[compact], slot, child.bounds, 0, 0);
        }
    };

    layout.packs.reserve(bvh.primitives.size() / 4 + 1);
    layout.nodes.reserve(bvh.nodes.size() / 2 + 1);  // a binary tree of L leaves has L - 1 inner nodes
    layout.nodes.emplace_back();
    if (bvh.root().is_leaf()) {
        set_from(0, 0, {0, true});
        set_child(layout.nodes[0], 1, AABB::empty(), 0, 0);
        return layout;
    }
    pending.push_back({0, kInvalidIndex, 0});
    while (!pending.empty()) {
        const Pending next = pending.back();
        pending.pop_back();
        uint32_t compact = 0;
        if (next.parent != kInvalidIndex) {
            compact = uint32_t(layout.nodes.size());
            layout.nodes.emplace_back();
            layout.nodes[next.parent].child[next.slot] = compact;
        }
        const std::vector<CollapseSlot> children = plan.slots(next.bvh_index);
        for (int slot = 0; slot < 2; ++slot) set_from(compact, slot, children[slot]);
        // Right first onto the stack, so the left subtree is laid out right after this node.
        for (int slot = 1; slot >= 0; --slot)
            if (!children[slot].leaf) pending.push_back({children[slot].node, compact, uint32_t(slot)});
    }
    return layout;
}

}  // namespace

BinaryLayout make_binary_layout(std::span<const Triangle> triangles, const Bvh& bvh) {
    BinaryLayout layout;
    LayoutParts parts = lay_out(triangles, bvh);
    layout.node_count = parts.nodes.size();
    // Join the parts: nodes first, packs after them, child indices turned into unit offsets.
    const size_t node_units = parts.nodes.size() * kNodeUnits;
    const size_t units = node_units + parts.packs.size() * kPackUnits;
    if (units > std::numeric_limits<uint32_t>::max())
        throw std::length_error("binary layout: " + std::to_string(units * kUnit) +
                                " bytes of nodes and triangles exceed the 32-bit offsets of its nodes (128 GiB)");
    for (CompactNode& node : parts.nodes) {
        for (int slot = 0; slot < 2; ++slot)
            node.child[slot] =
                uint32_t(node.lanes(slot) ? node_units + node.child[slot] * kPackUnits : node.child[slot] * kNodeUnits);
        order_children(node);
    }
    std::vector<CompactNode, HugePageAllocator<CompactNode>>& buffer = layout.buffer;
    buffer.resize((units * kUnit + sizeof(CompactNode) - 1) / sizeof(CompactNode));
    // std::copy, not memcpy: a tree without triangles has no packs, and memcpy from the null data()
    // of an empty vector is undefined even for zero bytes.
    std::copy(parts.nodes.begin(), parts.nodes.end(), buffer.begin());
    std::copy(parts.packs.begin(), parts.packs.end(),
              reinterpret_cast<TrianglePack*>(reinterpret_cast<char*>(buffer.data()) + node_units * kUnit));
    return layout;
}

namespace {

template <bool kAnyHit>
bool trace_one(const void* layout, const Ray& ray, Hit& hit) {
    return traverse<kAnyHit, false>(*static_cast<const BinaryLayout*>(layout), ray, hit, nullptr);
}

template <bool kAnyHit>
bool trace_one_stats(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
    return traverse<kAnyHit, true>(*static_cast<const BinaryLayout*>(layout), ray, hit, stats);
}

}  // namespace

SingleRayKernels binary_kernels() {
    return {&trace_one<false>, &trace_one_stats<false>, &trace_one<true>, &trace_one_stats<true>};
}

}  // namespace spacebvh::trace
