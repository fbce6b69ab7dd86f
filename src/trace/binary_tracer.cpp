#include <immintrin.h>

#include <cstring>

#include "spacebvh/tracer.hpp"
#include "trace/huge_page_allocator.hpp"
#include "trace/traversal_common.hpp"
#include "trace/triangle_pack.hpp"
#include "trace/watertight_triangle.hpp"

namespace spacebvh {

// One inner node holds the boxes of both children in the order the SSE slab test reads them:
// per axis [lo of child 0, lo of child 1, hi of child 0, hi of child 1].
struct alignas(64) CompactNode {
    float planes[3][4];
    // Inner child: index of its CompactNode, count = 0. Leaf child: its first TrianglePack, tested as
    // count > 0 lanes from there (LeafPacker).
    uint32_t child[2];
    uint32_t count[2];
};
static_assert(sizeof(CompactNode) == 64);

struct BinaryTracer::Layout {
    std::vector<CompactNode, trace::HugePageAllocator<CompactNode>> nodes;
    trace::TrianglePacks packs;
};

namespace {

// A push happens at most once per level, and build options cap the depth at 1024.
constexpr int kStackSize = 1024 + 8;
using trace::kFarScale;

void set_child(CompactNode& node, int slot, const AABB& box, uint32_t child, uint32_t count) {
    for (int axis = 0; axis < 3; ++axis) {
        node.planes[axis][slot] = box.lo[axis];
        node.planes[axis][slot + 2] = box.hi[axis];
    }
    node.child[slot] = child;
    node.count[slot] = count;
}

// Per-ray constants of the two-box slab test.
struct SlabRay {
    __m128 org[3], inv_dir[3];
#ifdef __AVX__
    __m128i plane_order[3];  // lane permutation that puts the entry planes first (vpermilps)
#else
    bool negative[3];
#endif
    explicit SlabRay(const Ray& ray) {
        for (int axis = 0; axis < 3; ++axis) {
            const float inv = 1.0f / ray.dir[axis];  // +-inf for axis-parallel rays
            org[axis] = _mm_set1_ps(ray.org[axis]);
            inv_dir[axis] = _mm_set1_ps(inv);
#ifdef __AVX__
            plane_order[axis] = std::signbit(inv) ? _mm_setr_epi32(2, 3, 0, 1) : _mm_setr_epi32(0, 1, 2, 3);
#else
            negative[axis] = std::signbit(inv);
#endif
        }
    }

    // The slab distances of one axis reordered so lanes 0,1 hold the entry planes and lanes 2,3 the
    // exit planes. With AVX a per-ray permutation does it; without, a branch on the direction's sign
    // (the same for the whole ray, so well predicted, but mispredicted at many a ray's first nodes).
    [[gnu::always_inline]] __m128 entry_planes_first(__m128 t, int axis) const {
#ifdef __AVX__
        return _mm_permutevar_ps(t, plane_order[axis]);
#else
        return negative[axis] ? _mm_shuffle_ps(t, t, _MM_SHUFFLE(1, 0, 3, 2)) : t;
#endif
    }
};

// Returns a 2-bit mask of the children whose boxes the ray enters within [tmin, tmax]; their entry
// distances go to `entry`. NaN (0 * inf: the ray lies in a slab plane) is ignored by the min/max
// operand order, which treats the ray as inside that slab: boxes are closed.
inline int intersect_children(const CompactNode& node, const SlabRay& slab, __m128 tmin, __m128 tmax, float entry[2]) {
    __m128 near = tmin;
    __m128 far = tmax;
    for (int axis = 0; axis < 3; ++axis) {
        __m128 t = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.planes[axis]), slab.org[axis]), slab.inv_dir[axis]);
        t = slab.entry_planes_first(t, axis);
        near = _mm_max_ps(t, near);
        far = _mm_min_ps(t, far);
    }
    const __m128 far_low = _mm_movehl_ps(far, far);  // exit distances into lanes 0,1
    const __m128 widened = _mm_mul_ps(far_low, _mm_set1_ps(kFarScale));
    const int mask = _mm_movemask_ps(_mm_cmple_ps(near, _mm_min_ps(widened, tmax))) & 3;
    _mm_storel_pi(reinterpret_cast<__m64*>(entry), near);
    return mask;
}

// A leaf's packs, out of line: inlined, the leaf test's many live values made the compiler spill and
// shuffle registers on every node visit, leaf or not (about 30 of the 130 instructions of a visit).
template <bool kAnyHit, bool kStats>
[[gnu::noinline]] bool test_leaf(const trace::TrianglePack* packs, uint32_t first, uint32_t count, const Ray& ray,
                                 const trace::WatertightRay& shear, const trace::PackRay& pack_ray, float& tmax, Hit& hit,
                                 bool& found, TraversalStats* stats) {
    return trace::test_leaf_packs<false, kAnyHit, kStats>(packs, first, count, ray, shear, pack_ray, tmax, hit, found, stats);
}

// Closest hit (kAnyHit = false) or any hit. Leaf children are tested as soon as the ray enters them;
// of two inner children the nearer is visited first (the farther for any hit). Stack entries keep
// their entry distance, so a subtree entered beyond the closest hit found since it was pushed is
// skipped without fetching it.
template <bool kAnyHit, bool kStats>
bool traverse(const BinaryTracer::Layout& layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
    const SlabRay slab(ray);
    const trace::WatertightRay shear(ray);
    const trace::PackRay pack_ray(shear);
    const CompactNode* nodes = layout.nodes.data();
    const trace::TrianglePack* packs = layout.packs.data();
    const __m128 tmin4 = _mm_set1_ps(ray.tmin);
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
        const CompactNode& node = nodes[node_index];
        // The walk is bound by memory latency: start fetching both children (node or leaf triangles)
        // now, so the fetch overlaps this node's box tests. An inner child's first inner child is laid
        // out right after it: fetching that line too saves a wait one level further down (Sponza
        // random rays 1.04-1.08x; a third line was slower).
        for (int slot = 0; slot < 2; ++slot) {
            if (node.count[slot]) {
                trace::prefetch_pack(packs[node.child[slot]]);
            } else {
                const CompactNode* child = nodes + node.child[slot];
                _mm_prefetch(reinterpret_cast<const char*>(child), _MM_HINT_T0);
                _mm_prefetch(reinterpret_cast<const char*>(child + 1), _MM_HINT_T0);
            }
        }
        if constexpr (kStats) stats->nodes_visited += 2;
        float entry[2];
        const int mask = intersect_children(node, slab, tmin4, _mm_set1_ps(tmax), entry);

        // Entered leaves are tested at once, in slot order; then the entered inner children decide
        // where to go next. Every such choice is a branch, never a select: a predicted branch lets
        // the next node's fetch start while this node's box test is still in flight, where a select
        // (or an index computed from the mask) makes that address wait for the test. The selects
        // this replaced cost 1.3-1.5x on Sponza's primary rays and 1.1-1.2x on occlusion rays.
        const unsigned leaves = (node.count[0] != 0 ? 1u : 0u) | (node.count[1] != 0 ? 2u : 0u);
        const unsigned entered_leaves = unsigned(mask) & leaves;
        if (entered_leaves) [[unlikely]] {
            for (int slot = 0; slot < 2; ++slot)
                if (entered_leaves & (1u << slot))
                    if (test_leaf<kAnyHit, kStats>(packs, node.child[slot], node.count[slot], ray, shear, pack_ray, tmax, hit,
                                                   found, stats))
                        return true;
        }
        const unsigned inner = unsigned(mask) & ~leaves;
        if (inner == 3) {
            // Nearer first for the closest hit, farther first for any hit (see visits_after in
            // wide_kernel.inl for why and what it measured); at equal distances slot 0 goes first for
            // the closest hit, slot 1 for any hit, as before.
            if ((entry[1] < entry[0]) != kAnyHit) {
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

}  // namespace

BinaryTracer::BinaryTracer(const Scene& scene, const Bvh& bvh) : layout_(std::make_unique<Layout>()) {
    Layout& layout = *layout_;
    if (bvh.empty()) {
        // Nothing to hit: one node whose two children are empty boxes.
        layout.nodes.resize(1);
        set_child(layout.nodes[0], 0, AABB::empty(), 0, 0);
        set_child(layout.nodes[0], 1, AABB::empty(), 0, 0);
        return;
    }
    // Depth-first order: a node's first inner child directly follows it, so a descent tends to stay
    // within neighbouring cache lines. `pending` holds inner BVH nodes whose compact node is not made
    // yet, with the place (compact node, slot) that must point at it.
    struct Pending {
        uint32_t bvh_index, parent, slot;
    };
    std::vector<Pending> pending;
    trace::LeafPacker packer(scene, bvh, layout.packs);
    auto set_from = [&](uint32_t compact, int slot, uint32_t bvh_index) {
        const BvhNode& child = bvh.nodes[bvh_index];
        if (child.is_leaf()) {
            auto [first, count] = packer.add(child);
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
        set_from(0, 0, 0);
        set_child(layout.nodes[0], 1, AABB::empty(), 0, 0);
        return;
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
        const BvhNode& inner = bvh.nodes[next.bvh_index];
        for (int slot = 0; slot < 2; ++slot) set_from(compact, slot, inner.first + slot);
        // Right first onto the stack, so the left subtree is laid out right after this node.
        for (int slot = 1; slot >= 0; --slot)
            if (!bvh.nodes[inner.first + slot].is_leaf()) pending.push_back({inner.first + uint32_t(slot), compact, uint32_t(slot)});
    }
}

BinaryTracer::~BinaryTracer() = default;
BinaryTracer::BinaryTracer(BinaryTracer&&) noexcept = default;
BinaryTracer& BinaryTracer::operator=(BinaryTracer&&) noexcept = default;

Hit BinaryTracer::intersect(const Ray& ray) const {
    const trace::StandardFloatingPointMode mode;
    Hit hit;
    traverse<false, false>(*layout_, ray, hit, nullptr);
    return hit;
}

Hit BinaryTracer::intersect(const Ray& ray, TraversalStats& stats) const {
    const trace::StandardFloatingPointMode mode;
    Hit hit;
    traverse<false, true>(*layout_, ray, hit, &stats);
    return hit;
}

bool BinaryTracer::occluded(const Ray& ray) const {
    const trace::StandardFloatingPointMode mode;
    Hit unused;
    return traverse<true, false>(*layout_, ray, unused, nullptr);
}

bool BinaryTracer::occluded(const Ray& ray, TraversalStats& stats) const {
    const trace::StandardFloatingPointMode mode;
    Hit unused;
    return traverse<true, true>(*layout_, ray, unused, &stats);
}

void BinaryTracer::intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats) const {
    trace::intersect_batch(rays, hits, stats, [&](const Ray& ray, Hit& hit, TraversalStats* s) {
        return s ? traverse<false, true>(*layout_, ray, hit, s) : traverse<false, false>(*layout_, ray, hit, nullptr);
    });
}

void BinaryTracer::occluded(std::span<const Ray> rays, std::span<uint8_t> result, TraversalStats* stats) const {
    trace::occluded_batch(rays, result, stats, [&](const Ray& ray, Hit& hit, TraversalStats* s) {
        return s ? traverse<true, true>(*layout_, ray, hit, s) : traverse<true, false>(*layout_, ray, hit, nullptr);
    });
}

size_t BinaryTracer::memory_bytes() const {
    return layout_->nodes.size() * sizeof(CompactNode) + layout_->packs.size() * sizeof(trace::TrianglePack);
}

}  // namespace spacebvh
