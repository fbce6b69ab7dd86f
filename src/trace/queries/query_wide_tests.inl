// SPDX-License-Identifier: MIT
// The eight-wide layout's node tests (fused float slabs, AVX2 and FMA), without an include guard:
// query_walks.cpp includes them into its AVX2 namespace under that target, so a portable build has
// them too and runs them on CPUs that report AVX2 and FMA (chosen at run time). Expects
// query_node_tests.hpp included before, at namespace scope.
// ---------------------------------------------------------------------------------------------
// Fused float slabs over the eight-wide nodes.

// The kernels' fused slab constants (traversal_common.hpp, FusedSlabs: why the test is conservative,
// and why a NaN from an axis the ray does not move along leaves the bounds alone by the operand order
// of min and max), broadcast to the eight lanes. Empty slots hold empty boxes, which no ray enters.
struct WideRay {
    __m256 entry_scale[3], entry_offset[3], exit_scale[3], exit_offset[3];
    int entry_plane[3], exit_plane[3];
    explicit WideRay(const Ray& ray) {
        const FusedSlabs slabs(ray);
        for (int axis = 0; axis < 3; ++axis) {
            entry_scale[axis] = _mm256_set1_ps(FusedSlabs::lane(slabs.entry_scale, axis));
            entry_offset[axis] = _mm256_set1_ps(FusedSlabs::lane(slabs.entry_offset, axis));
            exit_scale[axis] = _mm256_set1_ps(FusedSlabs::lane(slabs.exit_scale, axis));
            exit_offset[axis] = _mm256_set1_ps(FusedSlabs::lane(slabs.exit_offset, axis));
            const bool negative = (slabs.negative >> axis) & 1u;
            entry_plane[axis] = 2 * axis + (negative ? 1 : 0);
            exit_plane[axis] = 2 * axis + (negative ? 0 : 1);
        }
    }
};

// Whether a ray takes the fused test (WideSlabQuery): tmin >= 0 (the constants assume it) and finite
// constants on every axis. Others, axis-aligned rays among them, take the binary layout's double
// slabs (SlabRay), which cull on an axis the ray does not move along where the fused constants would not.
inline bool wide_slabs_apply(const Ray& ray) { return ray.tmin >= 0.0f && FusedSlabs(ray).finite_axes == 7; }

[[gnu::always_inline]] inline unsigned wide_children(const WideNode<8>& node, const WideRay& ray, float tmin,
                                                     float tmax, __m256& near) {
    near = _mm256_set1_ps(tmin);
    __m256 far = _mm256_set1_ps(tmax);
    for (int axis = 0; axis < 3; ++axis) {
        const __m256 t_entry = _mm256_fmsub_ps(_mm256_load_ps(node.planes[ray.entry_plane[axis]]),
                                               ray.entry_scale[axis], ray.entry_offset[axis]);
        const __m256 t_exit = _mm256_fmsub_ps(_mm256_load_ps(node.planes[ray.exit_plane[axis]]), ray.exit_scale[axis],
                                              ray.exit_offset[axis]);
        near = _mm256_max_ps(t_entry, near);
        far = _mm256_min_ps(t_exit, far);
    }
    return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(near, far, _CMP_LE_OQ)));
}

// Starts fetching every line of what a child's test reads (a node's four, a pack's three), as the
// kernels do (wide_kernel.inl): incoherent rays wait on memory at nearly every node, and the first
// line alone leaves the node test waiting on the other three.
[[gnu::always_inline]] inline void prefetch_wide_child(const WideNode<8>* nodes, const TrianglePack* packs,
                                                       uint32_t child, uint32_t count) {
    if (count == 0) {
        const char* bytes = reinterpret_cast<const char*>(&nodes[child]);
        for (size_t line = 0; line < sizeof(WideNode<8>); line += 64) _mm_prefetch(bytes + line, _MM_HINT_T0);
    } else {
        prefetch_pack(packs[child]);
    }
}

// The walk of every leaf a ray with tmin >= 0 may cross within [tmin, tmax] over the eight-wide nodes,
// for walks whose answers do not depend on the order (all hits, counts, any hit). A node's leaves are
// tested one node test later, after the next inner node's: their packs, fetched with that node, arrive
// meanwhile, and their test then overlaps the fetch of that node's children instead of waiting for
// its own. visit_leaf(SlotEntry) returns true to stop the walk.
template <class VisitLeaf>
[[gnu::always_inline]] inline void walk_wide_leaves(const WideLayout<8>& wide, const Ray& ray, VisitLeaf&& visit_leaf) {
    const WideNode<8>* nodes = wide.nodes.data();
    const TrianglePack* packs = wide.packs.data();
    const WideRay boxes(ray);
    const float tmin = ray.tmin, tmax = ray.tmax;
    uint32_t stack[kStackSize * 4];  // inner nodes still to test: at most seven pushes per level
    int top = 0;
    SlotEntry leaves[8], next_leaves[8];
    int leaf_count = 0;
    uint32_t at = 0;  // the root, an inner node
    while (true) {
        const WideNode<8>& node = nodes[at];
        __m256 near;
        int next_count = 0;
        for (unsigned m = wide_children(node, boxes, tmin, tmax, near); m; m &= m - 1) {
            const int slot = __builtin_ctz(m);
            const uint32_t child = node.child[slot], count = node.count[slot];
            prefetch_wide_child(nodes, packs, child, count);
            if (count == 0)
                stack[top++] = child;
            else
                next_leaves[next_count++] = {child, count};
        }
        for (int i = 0; i < leaf_count; ++i)
            if (visit_leaf(leaves[i])) return;
        for (int i = 0; i < next_count; ++i) leaves[i] = next_leaves[i];
        leaf_count = next_count;
        if (top == 0) break;
        at = stack[--top];
    }
    for (int i = 0; i < leaf_count; ++i)
        if (visit_leaf(leaves[i])) return;
}

// The wide layout's nearest-first query: rays with tmin >= 0 only (the fused constants assume it). It
// walks as the closest-hit kernels do (wide_kernel.inl), leaves and inner nodes alike by entry
// distance; the bound is then a float at or above the best t so far. (Walks of every leaf on the ray
// take walk_wide_leaves above.)
class WideSlabQuery : public SlotQuery<ChildOrder::nearest_first, float> {
public:
    using Base = SlotQuery<ChildOrder::nearest_first, float>;
    using typename Base::Bound;
    using typename Base::Entry;
    static constexpr int kStackCapacity = kStackSize * 4;  // at most seven pushes per level

    WideSlabQuery(const WideLayout<8>& wide, const Ray& ray)
        : nodes_(wide.nodes.data()), packs_(wide.packs.data()), boxes_(ray), tmin_(ray.tmin) {}

    Entry root() const { return Base::make_entry(0, 0, tmin_); }

    [[gnu::always_inline]] int enter(Entry& entry, Bound bound, Entry* out) const {
        const WideNode<8>& node = nodes_[entry.child];
        __m256 near;
        const unsigned entered = wide_children(node, boxes_, tmin_, bound, near);
        if (entered == 0) return 0;
        alignas(32) float key[8];
        _mm256_store_ps(key, near);
        const int n = nearest_first(entered, key, entry, out, [&](int slot) {
            return Base::make_entry(node.child[slot], node.count[slot], key[slot]);
        });
        prefetch_wide_child(nodes_, packs_, entry.child, entry.count);  // the child visited next
        return n;
    }

private:
    const WideNode<8>* nodes_;
    const TrianglePack* packs_;
    WideRay boxes_;
    float tmin_;
};
