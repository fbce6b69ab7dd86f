// SPDX-License-Identifier: MIT
// The lane tests of a packet (packet_kernel.inl traces with them): its rays in structure-of-arrays
// form, the frustum bounding them all, and boxes and triangles tested against S::kLanes rays at once,
// each lane the single-ray kernel's operations in the same order, so each decides exactly as the
// single-ray test would. Included by kernel_instances.cpp before packet_kernel.inl, inside a policy
// namespace.

// The interval bounds of a packet: every ray's origin and inverse direction lie in these boxes.
struct PacketFrustum {
    float org_lo[3], org_hi[3], inv_lo[3], inv_hi[3];
    int entry_plane[3], exit_plane[3];
    float tmin_lo, tmax_hi;
};

// The rays of a packet in structure-of-arrays form, so the tests below run over S::kLanes rays at
// once. Entries from `count` up to the next multiple of the lane count copy the first ray's origin
// and direction (so bounds over whole chunks are the packet's own) with tmin = +inf, tmax = -inf:
// they enter nothing.
struct PacketRaysSoA {
    alignas(64) float org[3][kMaxPacket];
    alignas(64) float dir[3][kMaxPacket];
    alignas(64) float inv_dir[3][kMaxPacket];
    alignas(64) float tmin[kMaxPacket];
    alignas(64) float tmax[kMaxPacket];
    alignas(64) float shear_x[kMaxPacket];  // WatertightRay's, for the triangle test over rays
    alignas(64) float shear_y[kMaxPacket];
};

// Rays base .. base + 7 into the SoA arrays. A Ray is eight floats (origin, direction, tmin, tmax),
// so with 8-lane AVX the eight rays are an 8 x 8 transpose in registers (24 shuffles); the copy
// field by field costs several times that, a large share of a packet of cheap rays.
template <class S>
[[gnu::always_inline]] inline void load_eight_rays(const Ray* rays, uint32_t base, PacketRaysSoA& soa) {
    static_assert(sizeof(Ray) == 8 * sizeof(float) && offsetof(Ray, dir) == 3 * sizeof(float) &&
                  offsetof(Ray, tmin) == 6 * sizeof(float) && offsetof(Ray, tmax) == 7 * sizeof(float));
    if constexpr (S::kLanes == 8 && !S::kScalarTriangles) {
        const float* p = reinterpret_cast<const float*>(rays + base);
        __m256 row[8];
        for (int k = 0; k < 8; ++k) row[k] = _mm256_loadu_ps(p + 8 * k);
        __m256 pair[8], quad[8];
        for (int k = 0; k < 8; k += 2) {
            pair[k] = _mm256_unpacklo_ps(row[k], row[k + 1]);
            pair[k + 1] = _mm256_unpackhi_ps(row[k], row[k + 1]);
        }
        for (int k = 0; k < 8; k += 4) {
            quad[k] = _mm256_shuffle_ps(pair[k], pair[k + 2], _MM_SHUFFLE(1, 0, 1, 0));
            quad[k + 1] = _mm256_shuffle_ps(pair[k], pair[k + 2], _MM_SHUFFLE(3, 2, 3, 2));
            quad[k + 2] = _mm256_shuffle_ps(pair[k + 1], pair[k + 3], _MM_SHUFFLE(1, 0, 1, 0));
            quad[k + 3] = _mm256_shuffle_ps(pair[k + 1], pair[k + 3], _MM_SHUFFLE(3, 2, 3, 2));
        }
        float* field[8] = {soa.org[0] + base, soa.org[1] + base, soa.org[2] + base, soa.dir[0] + base,
                           soa.dir[1] + base, soa.dir[2] + base, soa.tmin + base,   soa.tmax + base};
        for (int k = 0; k < 4; ++k) {
            _mm256_store_ps(field[k], _mm256_permute2f128_ps(quad[k], quad[k + 4], 0x20));
            _mm256_store_ps(field[k + 4], _mm256_permute2f128_ps(quad[k], quad[k + 4], 0x31));
        }
    } else {
        for (uint32_t i = base; i < base + 8; ++i) {
            for (int axis = 0; axis < 3; ++axis) {
                soa.org[axis][i] = rays[i].org[axis];
                soa.dir[axis][i] = rays[i].dir[axis];
            }
            soa.tmin[i] = rays[i].tmin;
            soa.tmax[i] = rays[i].tmax;
        }
    }
}

// The `count` rays in `soa`, padded to `padded_count` (a multiple of the lane count) as PacketRaysSoA
// says, with their inverse directions: divided S::kLanes rays at a time, the same correctly rounded
// divisions as the single-ray kernel's.
template <class S>
[[gnu::always_inline]] inline void load_packet(const Ray* rays, uint32_t count, uint32_t padded_count,
                                               PacketRaysSoA& soa) {
    const uint32_t whole_chunks_end = count / 8 * 8;
    for (uint32_t base = 0; base < whole_chunks_end; base += 8) load_eight_rays<S>(rays, base, soa);
    for (uint32_t i = whole_chunks_end; i < count; ++i) {
        for (int axis = 0; axis < 3; ++axis) {
            soa.org[axis][i] = rays[i].org[axis];
            soa.dir[axis][i] = rays[i].dir[axis];
        }
        soa.tmin[i] = rays[i].tmin;
        soa.tmax[i] = rays[i].tmax;
    }
    for (uint32_t i = count; i < padded_count; ++i) {
        for (int axis = 0; axis < 3; ++axis) {
            soa.org[axis][i] = rays[0].org[axis];
            soa.dir[axis][i] = rays[0].dir[axis];
        }
        soa.tmin[i] = kInfinity;
        soa.tmax[i] = -kInfinity;
    }
    for (uint32_t base = 0; base < padded_count; base += S::kLanes)
        for (int axis = 0; axis < 3; ++axis)
            S::store(soa.inv_dir[axis] + base, S::div(S::set1(1.0f), S::load(soa.dir[axis] + base)));
}

// The smallest and largest lane of `values`.
template <class S>
[[gnu::always_inline]] inline void lane_range(typename S::F lo_values, typename S::F hi_values, float& lo, float& hi) {
    alignas(64) float lo_lanes[S::kLanes], hi_lanes[S::kLanes];
    S::store(lo_lanes, lo_values);
    S::store(hi_lanes, hi_values);
    lo = lo_lanes[0];
    hi = hi_lanes[0];
    for (int j = 1; j < S::kLanes; ++j) {
        lo = std::min(lo, lo_lanes[j]);
        hi = std::max(hi, hi_lanes[j]);
    }
}

// False when the rays do not all share the sign of each direction component (or one is zero, or an
// inverse direction is not finite): the entry and exit planes then differ between rays and the packet
// goes ray by ray. Bounds are taken over whole chunks of S::kLanes rays (the padding copies ray 0).
template <class S>
inline bool make_frustum(const PacketRaysSoA& rays, uint32_t padded_count, PacketFrustum& frustum) {
    using F = typename S::F;
    constexpr uint32_t L = uint32_t(S::kLanes);
    constexpr unsigned kAllLanes = (1u << L) - 1;
    const F zero = S::set1(0.0f);
    for (int axis = 0; axis < 3; ++axis) {
        F org_lo = S::load(rays.org[axis]), org_hi = org_lo, inv_lo = S::load(rays.inv_dir[axis]), inv_hi = inv_lo;
        unsigned negative = kAllLanes, positive = kAllLanes;
        for (uint32_t base = 0; base < padded_count; base += L) {
            const F org = S::load(rays.org[axis] + base), inv = S::load(rays.inv_dir[axis] + base);
            const F dir = S::load(rays.dir[axis] + base);
            negative &= S::less_mask(dir, zero);
            positive &= S::less_mask(zero, dir);
            org_lo = S::min(org_lo, org);
            org_hi = S::max(org_hi, org);
            inv_lo = S::min(inv_lo, inv);
            inv_hi = S::max(inv_hi, inv);
        }
        if (negative != kAllLanes && positive != kAllLanes) return false;
        lane_range<S>(org_lo, org_hi, frustum.org_lo[axis], frustum.org_hi[axis]);
        lane_range<S>(inv_lo, inv_hi, frustum.inv_lo[axis], frustum.inv_hi[axis]);
        if (!std::isfinite(frustum.inv_lo[axis]) || !std::isfinite(frustum.inv_hi[axis])) return false;
        const bool is_negative = negative == kAllLanes;
        frustum.entry_plane[axis] = 2 * axis + (is_negative ? 1 : 0);
        frustum.exit_plane[axis] = 2 * axis + (is_negative ? 0 : 1);
    }
    F tmin_lo = S::load(rays.tmin), tmax_hi = S::load(rays.tmax);
    for (uint32_t base = 0; base < padded_count; base += L) {
        tmin_lo = S::min(tmin_lo, S::load(rays.tmin + base));
        tmax_hi = S::max(tmax_hi, S::load(rays.tmax + base));
    }
    float unused;
    lane_range<S>(tmin_lo, tmin_lo, frustum.tmin_lo, unused);
    lane_range<S>(tmax_hi, tmax_hi, unused, frustum.tmax_hi);
    return true;
}

// Whether every ray's largest direction component is on axis `kz` (dominant_axis: ties to the lower
// axis), so all share the watertight test's shear axes.
template <class S>
inline bool all_dominant_on(const PacketRaysSoA& rays, uint32_t padded_count, int kz) {
    using F = typename S::F;
    constexpr uint32_t L = uint32_t(S::kLanes);
    constexpr unsigned kAllLanes = (1u << L) - 1;
    for (uint32_t base = 0; base < padded_count; base += L) {
        const F x = S::abs(S::load(rays.dir[0] + base)), y = S::abs(S::load(rays.dir[1] + base)),
                z = S::abs(S::load(rays.dir[2] + base));
        bool same;
        if (kz == 0)
            same = (S::less_mask(x, y) | S::less_mask(x, z)) == 0;  // x >= y and x >= z
        else if (kz == 1)
            same = S::less_mask(x, y) == kAllLanes && S::less_mask(y, z) == 0;  // y > x, y >= z
        else
            same = (S::less_mask(x, z) & S::less_mask(y, z)) == kAllLanes;  // z > x and z > y
        if (!same) return false;
    }
    return true;
}

// The shear constants of the watertight triangle test (WatertightRay's shear_x, shear_y) of every ray
// of a packet that shears along kx, ky, kz, into soa.shear_x and soa.shear_y.
template <class S>
[[gnu::always_inline]] inline void shear_packet(PacketRaysSoA& soa, uint32_t padded_count, int kx, int ky, int kz) {
    for (uint32_t base = 0; base < padded_count; base += S::kLanes) {
        const typename S::F dir_z = S::load(soa.dir[kz] + base);
        S::store(soa.shear_x + base, S::div(S::load(soa.dir[kx] + base), dir_z));
        S::store(soa.shear_y + base, S::div(S::load(soa.dir[ky] + base), dir_z));
    }
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

// The edge functions of one triangle (a lane of a TrianglePack) for S::kLanes rays that share the
// shear's axes kx, ky, kz: pack_edges with the roles of rays and triangles swapped, lane by lane the
// same float operations, so each lane decides exactly as the single-ray test would.
template <class S>
[[gnu::always_inline]] inline void edges_over_rays(const TrianglePack& pack, int lane, const PacketRaysSoA& rays,
                                                   uint32_t base, int kx, int ky, int kz, float* u_out, float* v_out,
                                                   float* w_out, unsigned& outside, unsigned& inside) {
    using F = typename S::F;
    const F org_x = S::load(rays.org[kx] + base), org_y = S::load(rays.org[ky] + base),
            org_z = S::load(rays.org[kz] + base);
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
    const F ax = sheared_x[0], ay = sheared_y[0], bx = sheared_x[1], by = sheared_y[1], cx = sheared_x[2],
            cy = sheared_y[2];
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
[[gnu::always_inline]] inline unsigned rays_entering_child(const WideNode<S::kLanes>& node, uint32_t slot,
                                                           const PacketRaysSoA& rays, uint32_t base,
                                                           const PacketFrustum& frustum, float* entry = nullptr) {
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

// Four doubles (GCC and Clang vector extensions: AVX registers where the target has them).
typedef double Double4 __attribute__((vector_size(32)));
[[gnu::always_inline]] inline Double4 widened(const float* p) {
    typedef float Float4 __attribute__((vector_size(16)));
    Float4 f;
    __builtin_memcpy(&f, p, sizeof(f));
    return __builtin_convertvector(f, Double4);
}

// finish_crossing (watertight_triangle.hpp) for the S::kLanes rays from `base` at once: the same
// double operations lane by lane (plane_hit_distance's, the triangle's normal made once), so the same
// distances and the same decisions, four lanes per vector. Returns the lanes of `crossing` whose
// distance lies in the ray's [tmin, tmax]; their distances in `t` (other lanes may be left unset).
template <class S>
[[gnu::always_inline]] inline unsigned crossings_in_range(const Vec3 vertex[3], const PacketRaysSoA& rays,
                                                          uint32_t base, unsigned crossing, double* t) {
    const Vec3 &v0 = vertex[0], &v1 = vertex[1], &v2 = vertex[2];
    const double e1x = double(v1.x) - v0.x, e1y = double(v1.y) - v0.y, e1z = double(v1.z) - v0.z;
    const double e2x = double(v2.x) - v0.x, e2y = double(v2.y) - v0.y, e2z = double(v2.z) - v0.z;
    const double nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
    unsigned in_range = 0;
    for (int j = 0; j < S::kLanes; j += 4) {
        if (!((crossing >> j) & 15u)) continue;  // no lane of these four to decide
        const uint32_t i = base + uint32_t(j);
        const Double4 px = double(v0.x) - widened(rays.org[0] + i), py = double(v0.y) - widened(rays.org[1] + i),
                      pz = double(v0.z) - widened(rays.org[2] + i);
        const Double4 distance =
            (nx * px + ny * py + nz * pz) /
            (nx * widened(rays.dir[0] + i) + ny * widened(rays.dir[1] + i) + nz * widened(rays.dir[2] + i));
        const auto inside = (distance >= widened(rays.tmin + i)) & (distance <= widened(rays.tmax + i));
        __builtin_memcpy(t + j, &distance, sizeof(distance));
        for (int k = 0; k < 4; ++k) in_range |= unsigned(inside[k] != 0) << (j + k);
    }
    return in_range & crossing;
}
