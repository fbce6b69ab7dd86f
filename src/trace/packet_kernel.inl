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
//   - packets whose rays do not share direction signs (coherence lost) fall back to single rays.
// Every ray-box and ray-triangle decision is lane by lane the single-ray kernel's (same answers, exactly).
// Included by kernel_instances.cpp after wide_kernel.inl, inside a policy namespace.

// The interval bounds of a packet: every ray's origin and inverse direction lie in these boxes.
struct PacketFrustum {
    float org_lo[3], org_hi[3], inv_lo[3], inv_hi[3];
    int entry_plane[3], exit_plane[3];
    float tmin_lo, tmax_hi;
};

// False when the rays do not all share the sign of each direction component (or one is zero): the
// entry and exit planes then differ between rays and the packet goes ray by ray. `inv_dir[axis][i]`
// holds 1 / rays[i].dir[axis].
inline bool make_frustum(const Ray* rays, const float (*inv_dir)[kMaxPacket], uint32_t count, PacketFrustum& frustum) {
    for (int axis = 0; axis < 3; ++axis) {
        const bool negative = rays[0].dir[axis] < 0.0f;
        frustum.org_lo[axis] = frustum.org_hi[axis] = rays[0].org[axis];
        frustum.inv_lo[axis] = frustum.inv_hi[axis] = inv_dir[axis][0];
        for (uint32_t i = 0; i < count; ++i) {
            const float d = rays[i].dir[axis];
            if (d == 0.0f || (d < 0.0f) != negative) return false;
            const float inv = inv_dir[axis][i];
            frustum.org_lo[axis] = std::min(frustum.org_lo[axis], rays[i].org[axis]);
            frustum.org_hi[axis] = std::max(frustum.org_hi[axis], rays[i].org[axis]);
            frustum.inv_lo[axis] = std::min(frustum.inv_lo[axis], inv);
            frustum.inv_hi[axis] = std::max(frustum.inv_hi[axis], inv);
        }
        if (!std::isfinite(frustum.inv_lo[axis]) || !std::isfinite(frustum.inv_hi[axis])) return false;
        frustum.entry_plane[axis] = 2 * axis + (negative ? 1 : 0);
        frustum.exit_plane[axis] = 2 * axis + (negative ? 0 : 1);
    }
    frustum.tmin_lo = rays[0].tmin;
    frustum.tmax_hi = rays[0].tmax;
    for (uint32_t i = 0; i < count; ++i) {
        frustum.tmin_lo = std::min(frustum.tmin_lo, rays[i].tmin);
        frustum.tmax_hi = std::max(frustum.tmax_hi, rays[i].tmax);
    }
    return true;
}

// Bit i set unless child i is certainly missed by every ray of the packet. Each ray's slab distance
// (p - o) * inv is bilinear in (o, inv), so over the packet it lies between the smallest and largest of
// the four corner products; the bounds are then widened by 2^-18 relative, far more than the rounding
// of either computation (and than kFarScale), so culling is conservative.
template <class S>
[[gnu::always_inline]] inline unsigned frustum_mask(const WideNode<S::kLanes>& node, const PacketFrustum& frustum) {
    using F = typename S::F;
    F lower = S::set1(frustum.tmin_lo), upper = S::set1(frustum.tmax_hi);
    for (int axis = 0; axis < 3; ++axis) {
        const F inv_lo = S::set1(frustum.inv_lo[axis]), inv_hi = S::set1(frustum.inv_hi[axis]);
        const F org_lo = S::set1(frustum.org_lo[axis]), org_hi = S::set1(frustum.org_hi[axis]);
        const F entry = S::load(node.planes[frustum.entry_plane[axis]]);
        const F entry_near = S::sub(entry, org_hi), entry_far = S::sub(entry, org_lo);
        const F entry_min = S::min(S::min(S::mul(entry_near, inv_lo), S::mul(entry_near, inv_hi)),
                                   S::min(S::mul(entry_far, inv_lo), S::mul(entry_far, inv_hi)));
        const F exit = S::load(node.planes[frustum.exit_plane[axis]]);
        const F exit_near = S::sub(exit, org_hi), exit_far = S::sub(exit, org_lo);
        const F exit_max = S::max(S::max(S::mul(exit_near, inv_lo), S::mul(exit_near, inv_hi)),
                                  S::max(S::mul(exit_far, inv_lo), S::mul(exit_far, inv_hi)));
        lower = S::max(entry_min, lower);
        upper = S::min(exit_max, upper);
    }
    const F grow = S::set1(1.0f + 0x1p-18f), shrink = S::set1(1.0f - 0x1p-18f);
    const F lower_widened = S::min(S::mul(lower, grow), S::mul(lower, shrink));
    const F upper_widened = S::max(S::mul(upper, grow), S::mul(upper, shrink));
    return S::hit_mask(lower_widened, upper_widened);
}

// The packet's rays in structure-of-arrays form, so the tests below run over S::kLanes rays at once.
// Entries from `count` up to the next multiple of the lane count hold a ray that enters nothing
// (tmin = +inf, tmax = -inf).
struct PacketRaysSoA {
    alignas(64) float org[3][kMaxPacket];
    alignas(64) float inv_dir[3][kMaxPacket];
    alignas(64) float tmin[kMaxPacket];
    alignas(64) float tmax[kMaxPacket];
    alignas(64) float shear_x[kMaxPacket];  // WatertightRay's, for the triangle test over rays
    alignas(64) float shear_y[kMaxPacket];
};

// The edge functions of one triangle (a lane of a TrianglePack) for S::kLanes rays that share the
// shear's axes kx, ky, kz: pack_edges with the roles of rays and triangles swapped, lane by lane the
// same float operations, so each lane decides exactly as the single-ray test would.
template <class S>
[[gnu::always_inline]] inline void edges_over_rays(const TrianglePack& pack, int lane, const PacketRaysSoA& rays, uint32_t base,
                                                   int kx, int ky, int kz, float* u_out, float* v_out, float* w_out,
                                                   unsigned& outside, unsigned& inside) {
    using F = typename S::F;
    const F org_x = S::load(rays.org[kx] + base), org_y = S::load(rays.org[ky] + base), org_z = S::load(rays.org[kz] + base);
    const F shear_x = S::load(rays.shear_x + base), shear_y = S::load(rays.shear_y + base);
    F sheared_x[3], sheared_y[3], magnitude = S::set1(0.0f), size = S::set1(0.0f);
    for (int k = 0; k < 3; ++k) {
        const F px = S::sub(S::set1(pack.vertex[k][kx][lane]), org_x);
        const F py = S::sub(S::set1(pack.vertex[k][ky][lane]), org_y);
        const F pz = S::sub(S::set1(pack.vertex[k][kz][lane]), org_z);
        const F shift_x = S::mul(shear_x, pz), shift_y = S::mul(shear_y, pz);
        sheared_x[k] = S::sub(px, shift_x);
        sheared_y[k] = S::sub(py, shift_y);
        const F vertex_magnitude = S::max(S::add(S::abs(px), S::abs(shift_x)), S::add(S::abs(py), S::abs(shift_y)));
        magnitude = S::max(magnitude, vertex_magnitude);
        size = S::max(size, S::max(S::abs(sheared_x[k]), S::abs(sheared_y[k])));
    }
    const F ax = sheared_x[0], ay = sheared_y[0], bx = sheared_x[1], by = sheared_y[1], cx = sheared_x[2], cy = sheared_y[2];
    const F u = S::sub(S::mul(cx, by), S::mul(cy, bx));
    const F v = S::sub(S::mul(ax, cy), S::mul(ay, cx));
    const F w = S::sub(S::mul(bx, ay), S::mul(by, ax));
    const F bound = S::add(S::mul(S::mul(S::set1(32.0f * 0x1p-24f), magnitude), size), S::set1(kUnderflowBound));
    const F negative_bound = S::sub(S::set1(0.0f), bound);
    const unsigned u_below = S::less_mask(u, negative_bound), v_below = S::less_mask(v, negative_bound),
                   w_below = S::less_mask(w, negative_bound);
    const unsigned u_above = S::less_mask(bound, u), v_above = S::less_mask(bound, v), w_above = S::less_mask(bound, w);
    outside = (u_below | v_below | w_below) & (u_above | v_above | w_above);
    inside = (u_above & v_above & w_above) | (u_below & v_below & w_below);
    S::store(u_out, u);
    S::store(v_out, v);
    S::store(w_out, w);
}

// Bit j set when ray base + j enters child `slot` of `node` within its [tmin, tmax]: for S::kLanes
// rays, each lane the operations of that child's lane in enter_children, in the same order (a NaN slab
// distance keeps the running bound; the exit distance widened by kFarScale; the rays of a packet share
// their entry and exit planes), so it never disagrees with the ray's own node test.
template <class S>
[[gnu::always_inline]] inline unsigned rays_entering_child(const WideNode<S::kLanes>& node, uint32_t slot, const PacketRaysSoA& rays,
                                                           uint32_t base, const PacketFrustum& frustum, float* entry = nullptr) {
    using F = typename S::F;
    F near = S::load(rays.tmin + base), far = S::load(rays.tmax + base);
    for (int axis = 0; axis < 3; ++axis) {
        const F org = S::load(rays.org[axis] + base), inv_dir = S::load(rays.inv_dir[axis] + base);
        const F t_entry = S::mul(S::sub(S::set1(node.planes[frustum.entry_plane[axis]][slot]), org), inv_dir);
        const F t_exit = S::mul(S::sub(S::set1(node.planes[frustum.exit_plane[axis]][slot]), org), inv_dir);
        near = S::max(t_entry, near);
        far = S::min(t_exit, far);
    }
    const F tmax = S::load(rays.tmax + base);
    if (entry) S::store(entry, near);
    return S::hit_mask(near, S::min(S::mul(far, S::set1(kFarScale)), tmax));
}

// rays_entering_child for rays base .. base + S::kLanes - 1, keeping only those after the packet's
// first active ray `first` (rays before it are known to miss; the first is handled on its own).
// Settled occlusion rays have tmax = -inf: they enter nothing. Counts one box test per unsettled
// ray considered.
template <class S, bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline unsigned later_rays_entering_child(const WideNode<S::kLanes>& node, uint32_t slot,
                                                                 const PacketRaysSoA& rays, uint32_t base, uint32_t first,
                                                                 uint32_t count, const uint8_t* occluded,
                                                                 const PacketFrustum& frustum, TraversalStats* stats,
                                                                 float* entry = nullptr) {
    constexpr uint32_t L = uint32_t(S::kLanes);
    unsigned entering = rays_entering_child<S>(node, slot, rays, base, frustum, entry);
    if (base <= first) entering &= ~((2u << (first - base)) - 1);
    if constexpr (kStats)
        for (uint32_t i = std::max(base, first + 1); i < std::min(base + L, count); ++i)
            stats->nodes_visited += !(kAnyHit && occluded[i]);
    return entering;
}

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

template <class S, bool kAnyHit, bool kStats>
void trace_packet(const WideLayout<S::kLanes>& layout, const Ray* rays, uint32_t count, Hit* hits, uint8_t* occluded,
                  TraversalStats* stats) {
    constexpr int W = S::kLanes;
    constexpr uint32_t L = uint32_t(S::kLanes);
    // The rays in structure-of-arrays form; entries from `count` up to the next multiple of L hold a
    // ray that enters nothing (tmin = +inf, tmax = -inf). A ray whose occlusion is settled gets
    // tmax = -inf: it enters no box again. Inverse directions and shears are divided L rays at a time
    // (the same correctly rounded divisions as the single-ray kernel's).
    PacketRaysSoA soa;
    alignas(64) float dir[3][kMaxPacket];
    for (uint32_t i = 0; i < count; ++i) {
        for (int axis = 0; axis < 3; ++axis) {
            soa.org[axis][i] = rays[i].org[axis];
            dir[axis][i] = rays[i].dir[axis];
        }
        soa.tmin[i] = rays[i].tmin;
        soa.tmax[i] = rays[i].tmax;
    }
    for (uint32_t i = count; i % L != 0; ++i) {
        for (int axis = 0; axis < 3; ++axis) {
            soa.org[axis][i] = 0.0f;
            dir[axis][i] = 1.0f;
        }
        soa.tmin[i] = kInfinity;
        soa.tmax[i] = -kInfinity;
    }
    for (uint32_t base = 0; base < count; base += L)
        for (int axis = 0; axis < 3; ++axis)
            S::store(soa.inv_dir[axis] + base, S::div(S::set1(1.0f), S::load(dir[axis] + base)));

    PacketFrustum frustum;
    if (!make_frustum(rays, soa.inv_dir, count, frustum)) {
        for (uint32_t i = 0; i < count; ++i) {
            Hit hit;
            const bool found = traverse<S, kAnyHit, kStats>(layout, rays[i], hit, stats);
            if constexpr (kAnyHit) occluded[i] = found;
            else hits[i] = hit;
        }
        return;
    }
    for (uint32_t i = 0; i < count; ++i) {
        if constexpr (kAnyHit) occluded[i] = 0;
        else hits[i] = Hit{};
    }

    // The shear axes of the watertight triangle test (WatertightRay): when every ray of the packet
    // shears along the same axes, leaves test triangles over rays with the shears kept in soa; the
    // WatertightRay of a ray that tests a leaf on its own is made when it first does.
    const WatertightRay first_shear(rays[0]);
    const int kx = first_shear.kx, ky = first_shear.ky, kz = first_shear.kz;
    bool same_shear_axes = true;
    for (uint32_t i = 1; i < count; ++i) same_shear_axes &= dominant_axis(rays[i].dir) == kz;
    if (same_shear_axes) {
        for (uint32_t base = 0; base < count; base += L) {
            const typename S::F dir_z = S::load(dir[kz] + base);
            S::store(soa.shear_x + base, S::div(S::load(dir[kx] + base), dir_z));
            S::store(soa.shear_y + base, S::div(S::load(dir[ky] + base), dir_z));
        }
    }
    union LazyShear {
        WatertightRay shear;
        LazyShear() {}  // left unmade: most packets never need most of them
    };
    LazyShear shears[kMaxPacket];
    uint8_t sheared[kMaxPacket];
    for (uint32_t i = 0; i < count; ++i) sheared[i] = 0;
    uint32_t unsettled = count;

    // parent, slot: the node whose child this is, so a leaf's box can be tested ray by ray.
    struct Entry {
        uint32_t child, count, first, parent, slot;
    };
    Entry stack[(W - 1) * 1024 + 1];
    int top = 0;
    Entry current{0, 0, 0, 0, 0};

    while (true) {
        if (current.count == 0) {
            const WideNode<W>& node = layout.nodes[current.child];
            uint32_t valid_children = 0;
            if constexpr (kStats)
                for (int slot = 0; slot < W; ++slot) valid_children += node.used(slot);
            alignas(32) float first_entry[W];
            uint32_t first_ray[W];
            unsigned assigned = 0;
            unsigned remaining = (1u << W) - 1;
            {
                // The first active ray tests all children at once.
                const uint32_t i = current.first;
                const float org[3] = {soa.org[0][i], soa.org[1][i], soa.org[2][i]};
                const float inv_dir[3] = {soa.inv_dir[0][i], soa.inv_dir[1][i], soa.inv_dir[2][i]};
                const PacketRay<S> ray{org, inv_dir, frustum.entry_plane, frustum.exit_plane};
                alignas(32) float entry[W];
                alignas(32) uint32_t slot[W];
                const int entered = enter_children<S>(node, ray, soa.tmin[i], soa.tmax[i], entry, slot);
                if constexpr (kStats) stats->nodes_visited += valid_children;
                for (int k = 0; k < entered; ++k) {
                    first_ray[slot[k]] = i;
                    first_entry[slot[k]] = entry[k];
                    assigned |= 1u << slot[k];
                    remaining &= ~(1u << slot[k]);
                }
            }
            // It missed some children: the packet's frustum culls most of them; each of the rest looks
            // for its first ray among the later ones, S::kLanes rays at a time.
            if (remaining) remaining &= frustum_mask<S>(node, frustum);
            for (; remaining; remaining &= remaining - 1) {
                const uint32_t child_slot = uint32_t(__builtin_ctz(remaining));
                for (uint32_t base = (current.first + 1) / L * L; base < count; base += L) {
                    alignas(64) float entry[L];
                    const unsigned entering = later_rays_entering_child<S, kAnyHit, kStats>(
                        node, child_slot, soa, base, current.first, count, occluded, frustum, stats, entry);
                    if (!entering) continue;
                    const uint32_t lane = uint32_t(__builtin_ctz(entering));
                    first_ray[child_slot] = base + lane;
                    first_entry[child_slot] = entry[lane];
                    assigned |= 1u << child_slot;
                    break;
                }
            }
            if (assigned) {
                // In visits_after's order (wide_kernel.inl) by the entry distance of each child's first ray;
                // the rest go on the stack.
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
                    stack[top++] = {node.child[order[k]], node.count[order[k]], first_ray[order[k]], current.child, order[k]};
                current = {node.child[order[n - 1]], node.count[order[n - 1]], first_ray[order[n - 1]], current.child, order[n - 1]};
                if (current.count == 0) prefetch_node(layout.nodes[current.child]);
                continue;
            }
        } else {
            // Only the first active ray is known to enter the leaf: the others test its box first
            // (six planes against a pack test of four triangles), S::kLanes rays at a time.
            const WideNode<W>& parent = layout.nodes[current.parent];
            // The rays that enter the leaf: the box test only reads each ray's own tmax, which only
            // its own triangle tests change, so all of them can be found before any is tested.
            unsigned entering_chunk[kMaxPacket / L];  // bit j of chunk c: ray c * L + j enters the leaf
            for (uint32_t c = 0; c * L < count; ++c) entering_chunk[c] = 0;
            if (!(kAnyHit && occluded[current.first])) entering_chunk[current.first / L] = 1u << (current.first % L);
            for (uint32_t base = (current.first + 1) / L * L; base < count; base += L) {
                entering_chunk[base / L] |= later_rays_entering_child<S, kAnyHit, kStats>(
                    parent, current.slot, soa, base, current.first, count, occluded, frustum, stats);
            }
            // Each ray meets the leaf's triangles in lane order with its own tmax, whichever way they
            // are tested, so both ways give the same answers.
            for (uint32_t base = current.first / L * L; base < count; base += L) {
                unsigned entering = entering_chunk[base / L];
                if (!S::kScalarTriangles && same_shear_axes && 2 * uint32_t(__builtin_popcount(entering)) >= L) {
                    // Most of these rays enter: one triangle against L rays at a time.
                    for (uint32_t lane_index = 0; lane_index < current.count && entering; ++lane_index) {
                        const TrianglePack& pack = layout.packs[current.child + lane_index / 4];
                        const int lane = int(lane_index % 4);
                        if constexpr (kStats)
                            if (lane == 0)
                                stats->triangles_tested += uint64_t(__builtin_popcount(entering)) * std::min(4u, current.count - lane_index);
                        alignas(64) float u[L], v[L], w[L];
                        unsigned outside, inside;
                        edges_over_rays<S>(pack, lane, soa, base, kx, ky, kz, u, v, w, outside, inside);
                        unsigned candidates = entering & ~outside;
                        if (!candidates) continue;
                        Vec3 vertex[3];
                        pack_triangle(pack, lane, vertex);
                        for (; candidates; candidates &= candidates - 1) {
                            const uint32_t j = uint32_t(__builtin_ctz(candidates));
                            const uint32_t i = base + j;
                            TriangleHit candidate;
                            const bool crossed =
                                (inside >> j) & 1
                                    ? finish_crossing(rays[i], vertex[0], vertex[1], vertex[2], soa.tmax[i], u[j], v[j], w[j], candidate)
                                    : decide_exactly(rays[i], vertex[0], vertex[1], vertex[2], soa.tmax[i], u[j], v[j], w[j], candidate);
                            if (!crossed) continue;
                            if constexpr (kAnyHit) {
                                occluded[i] = 1;
                                soa.tmax[i] = -kInfinity;
                                entering &= ~(1u << j);
                                if (--unsettled == 0) return;
                            } else {
                                soa.tmax[i] = candidate.t;
                                hits[i] = {candidate.t, pack.primitive[lane], candidate.u, candidate.v};
                            }
                        }
                    }
                    continue;
                }
                for (; entering; entering &= entering - 1) {
                    const uint32_t i = base + uint32_t(__builtin_ctz(entering));
                    if (!sheared[i]) {
                        new (&shears[i].shear) WatertightRay(rays[i]);
                        sheared[i] = 1;
                    }
                    const WatertightRay& shear = shears[i].shear;
                    const PackRay pack_ray(shear);
                    Hit unused;
                    bool found = false;
                    test_leaf<S, kAnyHit, kStats>(layout.packs.data(), current.child, current.count, rays[i], shear, pack_ray, soa.tmax[i],
                                                  kAnyHit ? unused : hits[i], found, stats);
                    if (kAnyHit && found) {
                        occluded[i] = 1;
                        soa.tmax[i] = -kInfinity;
                        if (--unsettled == 0) return;
                    }
                }
            }
        }
        if (top == 0) return;
        current = stack[--top];
    }
}
