// SPDX-License-Identifier: MIT
// Coherent packets (e.g. the primary rays of an 8x8 image tile) traced together through a wide BVH,
// after Wald, Boulos and Shirley, "Ray Tracing Deformable Scenes Using Dynamic Bounding Volume
// Hierarchies" (TOG 2007), the traversal the paper's "frustum" figures measure:
//   - first active ray: a node is entered with the index of the first ray that hits it; rays before it
//     are known to miss and are never looked at again below it;
//   - frustum culling: when the first active ray misses a child, an interval-arithmetic bound over the
//     whole packet (all origins x all inverse directions) culls the child for every ray at once;
//     only if that bound cannot rule it out are the later rays tested, eight at a time;
//   - at a leaf, the rays after the first test its box (eight at a time), and those that enter test
//     its triangles: one triangle against eight rays when the packet's rays share their shear
//     axes, else ray by ray;
//   - occlusion: a ray leaves the packet once it is blocked (per-chunk masks of the active rays
//     gate every box and triangle test; a blocked first ray hands its place to the next active
//     one), and the packet ends once every ray is blocked;
//   - packets whose rays do not share direction signs but fall in two sign octants are traced as one
//     packet per octant; the rest (incoherent rays, zero direction components) go ray by ray.
// Every ray-box and ray-triangle decision is lane by lane the single-ray kernel's (same answers, exactly).
// Included by kernel_instances.cpp after wide_kernel.inl and packet_rays.inl (the lane tests), inside
// a policy namespace.

// The rays of a packet still looking for an answer, L per chunk (bit j of chunk c: ray c * L + j):
// an occlusion ray leaves once it is blocked, and the packet ends once none is left; closest-hit
// rays stay to the end. Every box and triangle test is masked with these bits, so a settled ray
// enters nothing again; the occlusion answers are written from them once, at the end.
inline constexpr uint32_t kNoRay = ~0u;
template <uint32_t L>
struct ActivePacketRays {
    unsigned bits[kMaxPacket / L];
    uint32_t chunks, unsettled;

    explicit ActivePacketRays(uint32_t count) : chunks((count + L - 1) / L), unsettled(count) {
        for (uint32_t c = 0; c < chunks; ++c) bits[c] = (1u << L) - 1;
        if (count % L) bits[chunks - 1] = (1u << (count % L)) - 1;
    }
    // The active rays of chunk c after ray `first`.
    unsigned after(uint32_t c, uint32_t first) const {
        const uint32_t base = c * L;
        return base > first ? bits[c] : bits[c] & ~((2u << (first - base)) - 1);
    }
    // The first active ray at or after `first`, or kNoRay.
    uint32_t first_from(uint32_t first) const {
        uint32_t c = first / L;
        unsigned rest = bits[c] & ~((1u << (first % L)) - 1);
        while (!rest && ++c < chunks) rest = bits[c];
        return rest ? c * L + uint32_t(__builtin_ctz(rest)) : kNoRay;
    }
    // Settles the rays of chunk c in `blocked` (occluded); true when no ray of the packet is left.
    bool settle(uint32_t c, unsigned blocked) {
        bits[c] &= ~blocked;
        unsettled -= uint32_t(__builtin_popcount(blocked));
        return unsettled == 0;
    }
    // The occlusion answers: the settled rays are the blocked ones.
    void write_occlusion(uint8_t* occluded, uint32_t count) const {
        for (uint32_t i = 0; i < count; ++i) occluded[i] = !((bits[i / L] >> (i % L)) & 1u);
    }
};

// One ray of a packet as enter_children sees it: its origin and inverse direction broadcast on demand
// (cheap loads) instead of kept in registers per ray.
template <class S>
struct PacketRay {
    const float* org_scalar;
    const float* inv_dir_scalar;
    const int* entry_plane;
    const int* exit_plane;
    typename S::F org(int axis) const { return S::set1(org_scalar[axis]); }
    typename S::F inv_dir(int axis) const { return S::set1(inv_dir_scalar[axis]); }
};

// A subtree pending on a packet's stack. `first`: the first ray known to enter it; `parent`, `slot`:
// the node whose child it is, so the packet's later rays can test a leaf's box.
struct PacketStackEntry {
    uint32_t child, count, first, parent, slot;
};

// The shear axes of the watertight triangle test (WatertightRay's kx, ky, kz) when every ray of the
// packet shears along the first ray's (`shared`): then a leaf most of a chunk's rays enter tests one
// triangle against S::kLanes rays, the shears kept in the SoA arrays (shear_packet). Passed by value:
// plain values, which no store through `hits` can change, stay in registers.
struct PacketShearAxes {
    int kx, ky, kz;
    bool shared;
};

// The WatertightRay of each ray that tests a leaf on its own, made when it first does: most rays of
// most packets never need one.
struct LazyShears {
    union LazyShear {
        WatertightRay shear;
        LazyShear() {}  // left unmade until its ray needs it
    };
    LazyShear lazy[kMaxPacket];
    uint8_t made[kMaxPacket] = {};

    const WatertightRay& of(const Ray* rays, uint32_t i) {
        if (!made[i]) {
            new (&lazy[i].shear) WatertightRay(rays[i]);
            made[i] = 1;
        }
        return lazy[i].shear;
    }
};

// The children of `node` the packet enters (bit = slot), each with its first ray (the first active ray
// from `first` on that enters it) and that ray's entry distance. Ray `first` tests all children at
// once; the packet's frustum culls most of the children it misses, and each of the rest looks for its
// first ray among the later active ones, S::kLanes rays at a time.
template <class S, bool kStats>
[[gnu::always_inline]] inline unsigned first_rays_of_children(const WideNode<S::kLanes>& node, uint32_t first,
                                                              const PacketRaysSoA& soa, const PacketFrustum& frustum,
                                                              const ActivePacketRays<S::kLanes>& active,
                                                              uint32_t* first_ray, float* first_entry,
                                                              TraversalStats* stats) {
    constexpr int W = S::kLanes;
    constexpr uint32_t L = uint32_t(S::kLanes);
    unsigned assigned = 0;
    unsigned remaining = (1u << W) - 1;
    {
        const float org[3] = {soa.org[0][first], soa.org[1][first], soa.org[2][first]};
        const float inv_dir[3] = {soa.inv_dir[0][first], soa.inv_dir[1][first], soa.inv_dir[2][first]};
        const PacketRay<S> ray{org, inv_dir, frustum.entry_plane, frustum.exit_plane};
        alignas(32) float entry[W];
        alignas(32) uint32_t slot[W];
        const int entered = enter_children<S>(node, ray, soa.tmin[first], soa.tmax[first], entry, slot);
        if constexpr (kStats)
            for (int child = 0; child < W; ++child) stats->nodes_visited += node.used(child);
        for (int k = 0; k < entered; ++k) {
            first_ray[slot[k]] = first;
            first_entry[slot[k]] = entry[k];
            assigned |= 1u << slot[k];
            remaining &= ~(1u << slot[k]);
        }
    }
    if (remaining) remaining &= frustum_mask<S>(node, frustum);
    for (; remaining; remaining &= remaining - 1) {
        const uint32_t child_slot = uint32_t(__builtin_ctz(remaining));
        for (uint32_t c = (first + 1) / L; c < active.chunks; ++c) {
            const unsigned candidates = active.after(c, first);
            if (!candidates) continue;
            if constexpr (kStats) stats->nodes_visited += uint32_t(__builtin_popcount(candidates));
            alignas(64) float entry[L];
            const unsigned entering = candidates & rays_entering_child<S>(node, child_slot, soa, c * L, frustum, entry);
            if (!entering) continue;
            const uint32_t lane = uint32_t(__builtin_ctz(entering));
            first_ray[child_slot] = c * L + lane;
            first_entry[child_slot] = entry[lane];
            assigned |= 1u << child_slot;
            break;
        }
    }
    return assigned;
}

// Pushes the children in `assigned` (node `node_index`'s) in visits_after's order (wide_kernel.inl)
// by the entry distance of each one's first ray, all but the first to visit, which it returns.
template <bool kAnyHit, int W>
[[gnu::always_inline]] inline PacketStackEntry push_children(const WideNode<W>& node, uint32_t node_index,
                                                             unsigned assigned, const uint32_t* first_ray,
                                                             const float* first_entry, PacketStackEntry* stack,
                                                             int& top) {
    uint32_t order[W];
    int n = 0;
    for (unsigned bits = assigned; bits; bits &= bits - 1) {
        const uint32_t slot = uint32_t(__builtin_ctz(bits));
        int j = n++;
        while (j > 0 && visits_after<kAnyHit>(node, first_entry[slot], slot, first_entry[order[j - 1]], order[j - 1])) {
            order[j] = order[j - 1];
            --j;
        }
        order[j] = slot;
    }
    for (int k = 0; k < n - 1; ++k)
        stack[top++] = {node.child[order[k]], node.count[order[k]], first_ray[order[k]], node_index, order[k]};
    return {node.child[order[n - 1]], node.count[order[n - 1]], first_ray[order[n - 1]], node_index, order[n - 1]};
}

// The inner node `current`: sets `current` to the child to visit next, the other entered children
// pushed, and returns true; false when the packet enters no child.
template <class S, bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline bool enter_packet_node(const WideLayout<S::kLanes>& layout, const PacketRaysSoA& soa,
                                                     const PacketFrustum& frustum,
                                                     const ActivePacketRays<S::kLanes>& active,
                                                     PacketStackEntry& current, PacketStackEntry* stack, int& top,
                                                     TraversalStats* stats) {
    constexpr int W = S::kLanes;
    const WideNode<W>& node = layout.nodes[current.child];
    if constexpr (kAnyHit) {
        // A blocked first ray enters nothing: the node's first active ray at or after it takes its
        // place (rays before it miss the node or are settled).
        current.first = active.first_from(current.first);
        if (current.first == kNoRay) return false;
    }
    alignas(32) float first_entry[W];
    uint32_t first_ray[W];
    const unsigned assigned =
        first_rays_of_children<S, kStats>(node, current.first, soa, frustum, active, first_ray, first_entry, stats);
    if (!assigned) return false;
    current = push_children<kAnyHit>(node, current.child, assigned, first_ray, first_entry, stack, top);
    if (current.count == 0) prefetch_node(layout.nodes[current.child]);
    return true;
}

// The rays that enter the leaf `leaf` (bit j of entering[c]: ray c * L + j). Only its first ray is
// known to (unless it has been blocked since): the later active rays test its box (six planes against
// a pack test of four triangles), S::kLanes rays at a time. The box test only reads each ray's own
// tmax, which only its own triangle tests change, so all of them can be found before any is tested.
template <class S, bool kStats>
[[gnu::always_inline]] inline void rays_entering_leaf(const WideNode<S::kLanes>& parent, const PacketStackEntry& leaf,
                                                      const PacketRaysSoA& soa, const PacketFrustum& frustum,
                                                      const ActivePacketRays<S::kLanes>& active, unsigned* entering,
                                                      TraversalStats* stats) {
    constexpr uint32_t L = uint32_t(S::kLanes);
    const uint32_t first_chunk = leaf.first / L;
    for (uint32_t c = first_chunk; c < active.chunks; ++c) {
        const unsigned candidates = active.after(c, leaf.first);
        entering[c] = 0;
        if (!candidates) continue;
        if constexpr (kStats) stats->nodes_visited += uint32_t(__builtin_popcount(candidates));
        entering[c] = candidates & rays_entering_child<S>(parent, leaf.slot, soa, c * L, frustum);
    }
    entering[first_chunk] |= active.bits[first_chunk] & (1u << (leaf.first % L));
}

// The leaf's triangles against the rays of chunk `c` in `entering`, one triangle against S::kLanes
// rays at a time (the rays share their shear axes); near an edge or a vertex, the exact test ray by
// ray. Returns true when it blocks the last unsettled ray of an occlusion packet.
template <class S, bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline bool leaf_over_rays(const TrianglePack* packs, const PacketStackEntry& leaf, uint32_t c,
                                                  unsigned entering, const Ray* rays, PacketRaysSoA& soa,
                                                  PacketShearAxes axes, ActivePacketRays<S::kLanes>& active, Hit* hits,
                                                  TraversalStats* stats) {
    constexpr uint32_t L = uint32_t(S::kLanes);
    const uint32_t base = c * L;
    for (uint32_t lane_index = 0; lane_index < leaf.count && entering; ++lane_index) {
        const TrianglePack& pack = packs[leaf.child + lane_index / 4];
        const int lane = int(lane_index % 4);
        if constexpr (kStats)
            if (lane == 0)
                stats->triangles_tested +=
                    uint64_t(__builtin_popcount(entering)) * std::min(4u, leaf.count - lane_index);
        alignas(64) float u[L], v[L], w[L];
        unsigned outside, inside;
        edges_over_rays<S>(pack, lane, soa, base, axes.kx, axes.ky, axes.kz, u, v, w, outside, inside);
        const unsigned candidates = entering & ~outside;
        if (!candidates) continue;
        Vec3 vertex[3];
        pack_triangle(pack, lane, vertex);
        alignas(64) double t[L];
        unsigned crossed = candidates & inside ? crossings_in_range<S>(vertex, soa, base, candidates & inside, t) : 0;
        if constexpr (!kAnyHit)
            for (unsigned bits = crossed; bits; bits &= bits - 1) {
                const uint32_t j = uint32_t(__builtin_ctz(bits)), i = base + j;
                const float det = u[j] + v[j] + w[j];
                soa.tmax[i] = float(t[j]);
                hits[i] = {float(t[j]), pack.primitive[lane], v[j] / det, w[j] / det};
            }
        for (unsigned near_edge = candidates & ~inside; near_edge; near_edge &= near_edge - 1) {
            const uint32_t j = uint32_t(__builtin_ctz(near_edge)), i = base + j;
            TriangleHit candidate;
            if (!decide_exactly(rays[i], vertex[0], vertex[1], vertex[2], soa.tmax[i], u[j], v[j], w[j], candidate))
                continue;
            crossed |= 1u << j;
            if constexpr (!kAnyHit) {
                soa.tmax[i] = candidate.t;
                hits[i] = {candidate.t, pack.primitive[lane], candidate.u, candidate.v};
            }
        }
        if constexpr (kAnyHit) {
            if (!crossed) continue;
            entering &= ~crossed;
            if (active.settle(c, crossed)) return true;
        }
    }
    return false;
}

// The leaf's triangles against the rays of chunk `c` in `entering`, ray by ray with the single-ray
// leaf test. Returns true when it blocks the last unsettled ray of an occlusion packet.
template <class S, bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline bool leaf_ray_by_ray(const TrianglePack* packs, const PacketStackEntry& leaf, uint32_t c,
                                                   unsigned entering, const Ray* rays, PacketRaysSoA& soa,
                                                   LazyShears& shears, ActivePacketRays<S::kLanes>& active, Hit* hits,
                                                   TraversalStats* stats) {
    const uint32_t base = c * uint32_t(S::kLanes);
    for (; entering; entering &= entering - 1) {
        const uint32_t j = uint32_t(__builtin_ctz(entering)), i = base + j;
        const WatertightRay& shear = shears.of(rays, i);
        const PackRay pack_ray(shear);
        Hit unused;
        bool found = false;
        test_leaf<S, kAnyHit, kStats>(packs, leaf.child, leaf.count, rays[i], shear, pack_ray, soa.tmax[i],
                                      kAnyHit ? unused : hits[i], found, stats);
        if (kAnyHit && found && active.settle(c, 1u << j)) return true;
    }
    return false;
}

// The leaf `leaf` for every active ray that enters it. Each ray meets the leaf's triangles in lane
// order with its own tmax, whichever way they are tested, so both ways give the same answers.
// Returns true when the last unsettled ray of an occlusion packet is blocked.
template <class S, bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline bool trace_packet_leaf(const WideLayout<S::kLanes>& layout, const PacketStackEntry& leaf,
                                                     const Ray* rays, PacketRaysSoA& soa, const PacketFrustum& frustum,
                                                     PacketShearAxes axes, LazyShears& shears,
                                                     ActivePacketRays<S::kLanes>& active, Hit* hits,
                                                     TraversalStats* stats) {
    constexpr uint32_t L = uint32_t(S::kLanes);
    unsigned entering[kMaxPacket / L];
    rays_entering_leaf<S, kStats>(layout.nodes[leaf.parent], leaf, soa, frustum, active, entering, stats);
    const TrianglePack* packs = layout.packs.data();
    for (uint32_t c = leaf.first / L; c < active.chunks; ++c) {
        // Most of the chunk's rays enter: one triangle against all of them at a time.
        if (!S::kScalarTriangles && axes.shared && 2 * uint32_t(__builtin_popcount(entering[c])) >= L) {
            if (leaf_over_rays<S, kAnyHit, kStats>(packs, leaf, c, entering[c], rays, soa, axes, active, hits, stats))
                return true;
        } else if (leaf_ray_by_ray<S, kAnyHit, kStats>(packs, leaf, c, entering[c], rays, soa, shears, active, hits,
                                                       stats)) {
            return true;
        }
    }
    return false;
}

// Traces a packet whose rays share the sign of each direction component (nonzero) and returns true;
// returns false, having traced nothing, for any other packet.
template <class S, bool kAnyHit, bool kStats>
bool trace_coherent_packet(const WideLayout<S::kLanes>& layout, const Ray* rays, uint32_t count, Hit* hits,
                           uint8_t* occluded, TraversalStats* stats) {
    constexpr uint32_t L = uint32_t(S::kLanes);
    const uint32_t padded_count = (count + L - 1) / L * L;
    PacketRaysSoA soa;
    load_packet<S>(rays, count, padded_count, soa);
    PacketFrustum frustum;
    if (!make_frustum<S>(soa, padded_count, frustum)) return false;
    if constexpr (!kAnyHit)
        for (uint32_t i = 0; i < count; ++i) hits[i] = Hit{};
    const WatertightRay first_shear(rays[0]);
    const PacketShearAxes axes{first_shear.kx, first_shear.ky, first_shear.kz,
                               all_dominant_on<S>(soa, padded_count, first_shear.kz)};
    if (axes.shared) shear_packet<S>(soa, padded_count, axes.kx, axes.ky, axes.kz);
    LazyShears shears;

    ActivePacketRays<L> active(count);
    // Each node visited pushes at most W - 1 entries and the depth is at most 1024 (build options).
    PacketStackEntry stack[(S::kLanes - 1) * 1024 + 1];
    int top = 0;
    PacketStackEntry current{0, 0, 0, 0, 0};
    while (true) {
        if (current.count == 0) {
            if (enter_packet_node<S, kAnyHit, kStats>(layout, soa, frustum, active, current, stack, top, stats))
                continue;
        } else if (trace_packet_leaf<S, kAnyHit, kStats>(layout, current, rays, soa, frustum, axes, shears, active,
                                                         hits, stats)) {
            active.write_occlusion(occluded, count);  // every ray is blocked
            return true;
        }
        if (top == 0) {
            if constexpr (kAnyHit) active.write_occlusion(occluded, count);
            return true;
        }
        current = stack[--top];
    }
}

// A packet, coherent or not. Rays that disagree in direction signs but fall in at most two sign
// octants (a tile across the horizon, or across any plane where a direction component changes sign)
// are traced as one packet per octant, so such tiles stay packets; other rays (incoherent ones, or
// with a zero direction component) go ray by ray.
template <class S, bool kAnyHit, bool kStats>
void trace_packet(const WideLayout<S::kLanes>& layout, const Ray* rays, uint32_t count, Hit* hits, uint8_t* occluded,
                  TraversalStats* stats) {
    if (trace_coherent_packet<S, kAnyHit, kStats>(layout, rays, count, hits, occluded, stats)) return;
    uint8_t octant[kMaxPacket];
    unsigned octants = 0;
    for (uint32_t i = 0; i < count; ++i) {
        octant[i] = uint8_t((rays[i].dir.x < 0.0f) | (rays[i].dir.y < 0.0f) << 1 | (rays[i].dir.z < 0.0f) << 2);
        octants |= 1u << octant[i];
    }
    // Rays spread over more than two octants are incoherent (random or diffuse rays): sub-packets of
    // them would share little traversal, so they go ray by ray.
    if (__builtin_popcount(octants) > 2) {
        for (uint32_t i = 0; i < count; ++i) {
            Hit hit;
            const bool found = traverse<S, kAnyHit, kStats>(layout, rays[i], hit, stats);
            if constexpr (kAnyHit)
                occluded[i] = found;
            else
                hits[i] = hit;
        }
        return;
    }
    Ray group[kMaxPacket];
    uint32_t index[kMaxPacket];
    Hit group_hits[kMaxPacket];
    uint8_t group_occluded[kMaxPacket];
    for (uint8_t signs = 0; signs < 8; ++signs) {
        uint32_t size = 0;
        for (uint32_t i = 0; i < count; ++i)
            if (octant[i] == signs) {
                index[size] = i;
                group[size++] = rays[i];
            }
        if (size == 0) continue;
        if (size < count &&
            trace_coherent_packet<S, kAnyHit, kStats>(layout, group, size, group_hits, group_occluded, stats)) {
            for (uint32_t k = 0; k < size; ++k) {
                if constexpr (kAnyHit)
                    occluded[index[k]] = group_occluded[k];
                else
                    hits[index[k]] = group_hits[k];
            }
            continue;
        }
        for (uint32_t k = 0; k < size; ++k) {
            Hit hit;
            const bool found = traverse<S, kAnyHit, kStats>(layout, group[k], hit, stats);
            if constexpr (kAnyHit)
                occluded[index[k]] = found;
            else
                hits[index[k]] = hit;
        }
    }
}
