// SPDX-License-Identifier: MIT
// The single-ray kernels of wide BVHs, written once over a node-test policy `S`. kernel_instances.cpp
// includes this file once per instruction set, inside a namespace that defines the policies and under
// `#pragma GCC target`, so each copy is compiled for its instructions and chosen at run time.
//
// A policy S provides: kLanes (the node width W), the vector type F with load/store/set1/sub/mul/min/max
// and fmsub (a * b - c, rounded once), hit_mask(near, limit) (bit i: near[i] <= limit[i]),
// collect(mask, near, entry, slot) (writes the entry distances and slots of the hit children in slot
// order, returns their number), and kScalarTriangles (test leaf triangles one at a time with the scalar test, for the
// reference kernel). No lambdas here: they would not inherit the target of the pragma region.

// Where, in bytes from the first plane of a node's SoA boxes (planes kStride bytes apart: x low, x
// high, y low, ...), the planes are that a ray enters and leaves through, per octant (bit k of the
// index: the direction is negative along axis k, and the ray enters through the upper plane). Looked
// up once per ray: every node test adds them to the node's address as they are, where plane indices
// would cost a shift each, and the set-up is one address instead of a dozen bit operations per axis.
struct PlaneOffsets {
    uint32_t entry[3], exit[3];
};
template <size_t kStride>
inline constexpr std::array<PlaneOffsets, 8> kOctantPlaneOffsets = [] {
    std::array<PlaneOffsets, 8> table{};
    for (uint32_t octant = 0; octant < 8; ++octant)
        for (uint32_t axis = 0; axis < 3; ++axis) {
            const uint32_t negative = (octant >> axis) & 1u;
            table[octant].entry[axis] = uint32_t((2 * axis + negative) * kStride);
            table[octant].exit[axis] = uint32_t((2 * axis + 1 - negative) * kStride);
        }
    return table;
}();

// The plane `offset` bytes from `first` (kOctantPlaneOffsets).
template <class T>
[[gnu::always_inline]] inline const T* plane_at(const T* first, uint32_t offset) {
    return reinterpret_cast<const T*>(reinterpret_cast<const char*>(first) + offset);
}

// Per-ray constants of the single-ray box test, and which plane of a node's SoA boxes the ray enters
// through (the lower one for a positive direction) and which it leaves through.
// kFused: the fused slab constants of each axis (traversal_common.hpp, FusedSlabs: why the test stays
// conservative) broadcast; every axis must have finite ones. Otherwise (a direction component 0, as
// axis-aligned rays have, or o / d beyond the float range) the origin and inverse direction of the
// subtract-multiply test: there (p - o) * (1/d) with 1/d = +-inf is +-inf on the side of the slab the
// origin is not on, and NaN (bound unchanged) on a plane through it, so the axis still culls every box
// whose slab misses the origin; the fused constants of such an axis would cull nothing.
// kStride: the bytes from one plane of a node's boxes to the next.
template <class S, bool kFused, size_t kStride>
struct RayBoxes {
    typename S::F entry_scale[3], entry_offset[3], exit_scale[3], exit_offset[3];  // kFused
    typename S::F org[3], inv_dir[3];                                              // !kFused
    const PlaneOffsets* planes;

    RayBoxes(const Ray& ray, const FusedSlabs& slabs) {
        unsigned octant = slabs.negative;
        for (int axis = 0; axis < 3; ++axis) {
            if constexpr (kFused) {
                entry_scale[axis] = S::set1(FusedSlabs::lane(slabs.entry_scale, axis));
                entry_offset[axis] = S::set1(FusedSlabs::lane(slabs.entry_offset, axis));
                exit_scale[axis] = S::set1(FusedSlabs::lane(slabs.exit_scale, axis));
                exit_offset[axis] = S::set1(FusedSlabs::lane(slabs.exit_offset, axis));
            } else {
                org[axis] = S::set1(ray.org[axis]);
                inv_dir[axis] = S::set1(1.0f / ray.dir[axis]);
            }
        }
        // Not fused: the sign of 1/d, -0 included (FusedSlabs::negative clears lane 0 of a ray without
        // finite constants).
        if constexpr (!kFused)
            octant = unsigned(std::signbit(ray.dir[0])) | unsigned(std::signbit(ray.dir[1])) << 1 |
                     unsigned(std::signbit(ray.dir[2])) << 2;
        planes = &kOctantPlaneOffsets<kStride>[octant];
    }
};

// The slab distances of one axis from the planes the ray enters and leaves through: fused, or (p - o)
// * (1/d), whose exit distances the caller widens by kFarScale (Ize 2013, as the packet kernel).
template <class S, bool kFused, size_t kStride>
[[gnu::always_inline]] inline void slab_distances(typename S::F entry_planes, typename S::F exit_planes,
                                                  const RayBoxes<S, kFused, kStride>& ray, int axis,
                                                  typename S::F& t_entry, typename S::F& t_exit) {
    if constexpr (kFused) {
        t_entry = S::fmsub(entry_planes, ray.entry_scale[axis], ray.entry_offset[axis]);
        t_exit = S::fmsub(exit_planes, ray.exit_scale[axis], ray.exit_offset[axis]);
    } else {
        t_entry = S::mul(S::sub(entry_planes, ray.org[axis]), ray.inv_dir[axis]);
        t_exit = S::mul(S::sub(exit_planes, ray.org[axis]), ray.inv_dir[axis]);
    }
}

// The mask of the children entered: near <= far, the far distance widened where the test is not fused.
template <class S, bool kFused>
[[gnu::always_inline]] inline unsigned entered_mask(typename S::F near, typename S::F far, typename S::F tmax) {
    if constexpr (kFused) return S::hit_mask(near, far);
    return S::hit_mask(near, S::min(S::mul(far, S::set1(kFarScale)), tmax));
}

// Tests all child boxes of `node` for a single ray (RayBoxes): returns the mask of the children entered
// within [tmin, tmax] (broadcast; bit = slot) and sets `near` to every lane's entry distance. A NaN slab distance
// (0 * inf: a plane through the origin on an axis the ray does not move along, or an empty slot there)
// leaves the running bound unchanged, by the operand order of min and max.
template <class S, bool kFused, size_t kStride>
[[gnu::always_inline]] inline unsigned child_hit_mask(const WideNode<S::kLanes>& node,
                                                      const RayBoxes<S, kFused, kStride>& ray, typename S::F tmin,
                                                      typename S::F tmax, typename S::F& near) {
    near = tmin;
    typename S::F far = tmax;
    for (int axis = 0; axis < 3; ++axis) {
        typename S::F t_entry, t_exit;
        slab_distances(S::load(plane_at(node.planes[0], ray.planes->entry[axis])),
                       S::load(plane_at(node.planes[0], ray.planes->exit[axis])), ray, axis, t_entry, t_exit);
        near = S::max(t_entry, near);
        far = S::min(t_exit, far);
    }
    return entered_mask<S, kFused>(near, far, tmax);
}

// The same for a quantized node (quantized_layout.hpp): each plane decoded exactly as the encoder
// checked it, fma(float(code), scale, origin) rounded once, so the decoded box contains the child's
// float box and the slab test on it stays conservative. Slots without a child are masked off.
// Needs the policy's load_u8 (eight codes to floats) and fmadd (8-wide policies only).
template <class S, bool kFused, size_t kStride>
[[gnu::always_inline]] inline unsigned child_hit_mask(const QuantizedNode8& node,
                                                      const RayBoxes<S, kFused, kStride>& ray, typename S::F tmin,
                                                      typename S::F tmax, typename S::F& near) {
    near = tmin;
    typename S::F far = tmax;
    for (int axis = 0; axis < 3; ++axis) {
        const typename S::F scale = S::set1(node.scale[axis]), origin = S::set1(node.origin[axis]);
        const typename S::F entry_plane =
            S::fmadd(S::load_u8(plane_at(node.q[0], ray.planes->entry[axis])), scale, origin);
        const typename S::F exit_plane =
            S::fmadd(S::load_u8(plane_at(node.q[0], ray.planes->exit[axis])), scale, origin);
        typename S::F t_entry, t_exit;
        slab_distances(entry_plane, exit_plane, ray, axis, t_entry, t_exit);
        near = S::max(t_entry, near);
        far = S::min(t_exit, far);
    }
    return entered_mask<S, kFused>(near, far, tmax) & node.used_mask;
}

// The packet kernel's test of one ray against all child boxes (`Boxes`: its origin and inverse
// direction broadcast): the subtract-multiply slab test, lane-parallel, with the operand order of
// rays_entering_child (a NaN from 0 * inf, a ray lying in a slab plane, leaves the running bound
// unchanged: boxes are closed) and its conservative widening of the exit distance (kFarScale), so
// the two agree lane for lane. Returns the number of children entered within [tmin, tmax], their
// entry distances and slots in slot order.
template <class S, class Boxes>
[[gnu::always_inline]] inline int enter_children(const WideNode<S::kLanes>& node, const Boxes& ray, float tmin,
                                                 float tmax, float* entry, uint32_t* slot) {
    typename S::F near = S::set1(tmin), far = S::set1(tmax);
    for (int axis = 0; axis < 3; ++axis) {
        const typename S::F org = ray.org(axis), inv_dir = ray.inv_dir(axis);
        const typename S::F t_entry = S::mul(S::sub(S::load(node.planes[ray.entry_plane[axis]]), org), inv_dir);
        const typename S::F t_exit = S::mul(S::sub(S::load(node.planes[ray.exit_plane[axis]]), org), inv_dir);
        near = S::max(t_entry, near);
        far = S::min(t_exit, far);
    }
    const typename S::F limit = S::min(S::mul(far, S::set1(kFarScale)), S::set1(tmax));
    return S::collect(S::hit_mask(near, limit), near, entry, slot);
}

// A leaf's triangles: the shared pack test (triangle_pack.hpp), one at a time in the reference kernel.
template <class S, bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline bool test_leaf(const TrianglePack* packs, uint32_t first, uint32_t count, const Ray& ray,
                                             const WatertightRay& shear, const PackRay& pack_ray, float& tmax, Hit& hit,
                                             bool& found, TraversalStats* stats) {
    return test_leaf_packs<S::kScalarTriangles, kAnyHit, kStats>(packs, first, count, ray, shear, pack_ray, tmax, hit,
                                                                 found, stats);
}

// The order children are visited in (closest hits here; any hit only in the packet kernel: the
// single-ray kernel picks the farthest child, see traverse): true when child a (entered at entry_a)
// is visited after child b. Closest hit: nearest first, so the hit found first prunes the rest. Any
// hit: leaves first (a hit there ends the ray at once), then the inner children farthest first.
// Nearest first is the worst order for occlusion: diffuse rays start on a surface, whose
// neighbourhood they must cross but which rarely occludes them. Farthest first tests fewer boxes
// per occlusion ray than slot order for every ray kind, and far fewer than nearest first for
// diffuse rays.
template <bool kAnyHit, class Node>
[[gnu::always_inline]] inline bool visits_after(const Node& node, float entry_a, uint32_t slot_a, float entry_b,
                                                uint32_t slot_b) {
    if constexpr (kAnyHit) {
        const bool leaf_a = node.count[slot_a] != 0, leaf_b = node.count[slot_b] != 0;
        if (leaf_a != leaf_b) return leaf_b;
        return entry_a < entry_b;
    } else {
        return entry_a > entry_b;
    }
}

template <class Node>
[[gnu::always_inline]] inline void prefetch_node(const Node& node) {
    for (size_t line = 0; line < sizeof(Node); line += 64)
        _mm_prefetch(reinterpret_cast<const char*>(&node) + line, _MM_HINT_T0);
}

// Starts fetching a child the ray will visit soon: an inner node's lines (four, or two quantized), or
// the first triangle pack of a leaf (three lines); traversal is bound by the latency of these fetches.
// With the moller leaf test (`planes` not null), the leaf's planes line too.
template <class Node>
[[gnu::always_inline]] inline void prefetch_child(const Node* nodes, const TrianglePack* packs,
                                                  const PackPlanes* planes, uint32_t child, uint32_t count) {
    if (count == 0) {
        prefetch_node(nodes[child]);
    } else {
        prefetch_pack(packs[child]);
        if (planes) prefetch_pack_planes(planes[child]);
    }
}

// The per-ray constants of the leaf test that a kernel without the moller test does not need.
struct NoMollerRay {
    explicit NoMollerRay(const Ray&) {}
};

// A subtree pending on a single ray's stack, with the distance at which the ray enters it.
struct RayStackEntry {
    uint32_t child, count;
    float entry;
};

// Closest hit, three or more children entered (`first`, `second` and those left in `mask`): sorts
// their visit keys (visit_order.hpp: visits_after's order as integers), pushes all but the nearest,
// the last to visit deepest, and returns the nearest. 8-byte integer keys sort in a few min/max
// steps, far fewer instructions than an insertion sort of 12-byte stack entries.
template <int W, class Node>
[[gnu::always_inline]] inline RayStackEntry push_sorted_but_nearest(const Node& node, unsigned mask, uint32_t first,
                                                                    uint32_t second, const float* entry,
                                                                    RayStackEntry* stack, int& top) {
    uint64_t key[W];
    int n = 0;
    key[n++] = visit_key(entry[first], first);
    key[n++] = visit_key(entry[second], second);
    do {
        const uint32_t lane = uint32_t(__builtin_ctz(mask));
        mask &= mask - 1;
        key[n++] = visit_key(entry[lane], lane);
    } while (mask != 0);
    sort_visit_keys<W>(key, n);
    for (int i = n - 1; i > 0; --i) {
        const uint32_t lane = visit_key_slot(key[i]);
        stack[top++] = {node.child[lane], node.count[lane], entry[lane]};
    }
    const uint32_t lane = visit_key_slot(key[0]);
    return {node.child[lane], node.count[lane], entry[lane]};
}

// The bytes between two planes of a node's boxes: float planes, or a quantized node's codes.
template <class Node>
constexpr size_t plane_stride() {
    if constexpr (requires(const Node& node) { node.planes[0]; })
        return sizeof(std::declval<const Node&>().planes[0]);
    else
        return sizeof(std::declval<const Node&>().q[0]);
}

// Closest hit (kAnyHit = false) or any hit. Children a ray enters are visited nearest first; entries
// on the stack keep their entry distance, so a subtree entered beyond the closest hit found since is
// skipped when popped. kMoller: leaves take the moller leaf test (moller_filter.hpp) on layout.planes.
// Layout: WideLayout<S::kLanes>, or QuantizedLayout8 for an 8-wide policy.
template <class S, bool kAnyHit, bool kStats, bool kMoller, bool kFused, class Layout>
bool walk(const Layout& layout, const Ray& ray, const FusedSlabs& slabs, Hit& hit, TraversalStats* stats) {
    constexpr int W = S::kLanes;
    using Node = typename decltype(layout.nodes)::value_type;
    const RayBoxes<S, kFused, plane_stride<Node>()> boxes(ray, slabs);
    // Kept in locals: the compiler cannot tell that the writes to `hit` leave them alone, and would
    // load them from memory at every node of a closest-hit walk.
    const Node* const nodes = layout.nodes.data();
    const TrianglePack* const packs = layout.packs.data();
    const PackPlanes* const planes = kMoller ? layout.planes.data() : nullptr;
    const std::conditional_t<kMoller, MollerRay, NoMollerRay> moller(ray);
    const float tmin = ray.tmin;
    // The ray's interval broadcast once (tmax again after a leaf shortens it), not at every node.
    const typename S::F tmin_lanes = S::set1(tmin);
    // The triangle test's per-ray constants (three divisions) are made when the ray reaches its first
    // leaf: many rays (random rays around a small object) never do.
    WatertightRay shear;
    PackRay pack_ray;
    bool sheared = false;
    float tmax = ray.tmax;
    typename S::F tmax_lanes = S::set1(tmax);
    bool found = false;

    // Each node visited pushes at most W - 1 entries and the depth is at most 1024 (build options).
    RayStackEntry stack[(W - 1) * 1024 + 1];
    int top = 0;
    RayStackEntry current{0, 0, tmin};

    while (true) {
        if (current.count == 0) {
            const Node& node = nodes[current.child];
            if constexpr (kStats)
                for (int slot = 0; slot < W; ++slot) stats->nodes_visited += node.used(slot);
            typename S::F near;
            unsigned mask = child_hit_mask<S, kFused>(node, boxes, tmin_lanes, tmax_lanes, near);
            if (mask != 0) {
                // As Embree's single-ray traversal does: the entered children straight from the mask;
                // for the closest hit, one is followed at once (most nodes enter one), two are compared
                // directly, more are pushed and sorted on the stack, nearest visited first.
                alignas(64) float entry[W];
                S::store(entry, near);
                if constexpr (kAnyHit) {
                    // Any hit: the farthest entered child next (ties: the later slot), the others pushed
                    // unsorted in slot order, so they pop smallest subtree first (the layout orders a
                    // node's slots by decreasing size, wide_layout.cpp). A diffuse ray starts on a
                    // surface whose neighbourhood it must cross but which rarely occludes it, so the
                    // far child is the likelier occluder; and sorting them all costs more than it
                    // saves. Embree pushes unsorted too; sorting all of them (leaf children first,
                    // then farthest first, as the packets do) is slower.
                    uint32_t farthest = uint32_t(__builtin_ctz(mask));
                    for (unsigned rest = mask & (mask - 1); rest != 0; rest &= rest - 1) {
                        const uint32_t lane = uint32_t(__builtin_ctz(rest));
                        if (entry[lane] >= entry[farthest]) farthest = lane;
                    }
                    for (unsigned rest = mask & ~(1u << farthest); rest != 0; rest &= rest - 1) {
                        const uint32_t lane = uint32_t(__builtin_ctz(rest));
                        stack[top++] = {node.child[lane], node.count[lane], entry[lane]};
                    }
                    current = {node.child[farthest], node.count[farthest], entry[farthest]};
                    prefetch_child(nodes, packs, planes, current.child, current.count);
                    if (top > 0) prefetch_child(nodes, packs, planes, stack[top - 1].child, stack[top - 1].count);
                    continue;
                }
                const uint32_t first = uint32_t(__builtin_ctz(mask));
                mask &= mask - 1;
                if (mask == 0) {
                    current = {node.child[first], node.count[first], entry[first]};
                    prefetch_child(nodes, packs, planes, current.child, current.count);
                    continue;
                }
                const uint32_t second = uint32_t(__builtin_ctz(mask));
                mask &= mask - 1;
                if (mask == 0) {
                    // The order of visits_after (ties: the later slot first), chosen by selecting slots
                    // rather than by a branch (which child is nearer is a coin toss for the branch
                    // predictor; measured no faster, and no slower).
                    const bool first_next = visits_after<false>(node, entry[second], second, entry[first], first);
                    const uint32_t next = first_next ? first : second, later = first ^ second ^ next;
                    stack[top++] = {node.child[later], node.count[later], entry[later]};
                    current = {node.child[next], node.count[next], entry[next]};
                } else {
                    current = push_sorted_but_nearest<W>(node, mask, first, second, entry, stack, top);
                }
                prefetch_child(nodes, packs, planes, current.child, current.count);
                // The next pop is likely soon: fetch it too.
                prefetch_child(nodes, packs, planes, stack[top - 1].child, stack[top - 1].count);
                continue;
            }
        } else {
            if constexpr (kMoller) {
                if (test_leaf_moller<kAnyHit, kStats>(packs, planes, current.child, current.count, ray, moller, tmax,
                                                      hit, found, stats))
                    return true;
            } else {
                if (!sheared) {
                    shear = WatertightRay(ray);
                    pack_ray = PackRay(shear);
                    sheared = true;
                }
                if (test_leaf<S, kAnyHit, kStats>(packs, current.child, current.count, ray, shear, pack_ray, tmax, hit,
                                                  found, stats))
                    return true;
            }
            if constexpr (!kAnyHit) tmax_lanes = S::set1(tmax);
        }
        // Pop the nearest pending subtree that may still hold a closer hit.
        do {
            if (top == 0) return found;
            current = stack[--top];
        } while (!kAnyHit && current.entry > tmax);
    }
}

// A ray with finite fused slab constants on every axis takes the fused box test; the others (axis-
// aligned rays among them) the subtract-multiply one, which culls on every axis (RayBoxes).
template <class S, bool kAnyHit, bool kStats, bool kMoller = false, class Layout>
bool traverse(const Layout& layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
    const FusedSlabs slabs(ray);
    if (slabs.finite_axes == 7) [[likely]]
        return walk<S, kAnyHit, kStats, kMoller, true>(layout, ray, slabs, hit, stats);
    return walk<S, kAnyHit, kStats, kMoller, false>(layout, ray, slabs, hit, stats);
}
