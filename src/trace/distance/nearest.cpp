// SPDX-License-Identifier: MIT
#include "trace/distance/nearest.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "trace/distance/exact_distance.hpp"
#include "trace/queries/query_layout.hpp"
#include "trace/traversal/walk.hpp"

namespace spacebvh::trace::distance {

namespace {

typedef double Double8 __attribute__((vector_size(64)));
typedef float Float8 __attribute__((vector_size(32)));
typedef long long Mask8 __attribute__((vector_size(64)));

// The lower bound of a squared distance computed in double: lo - p, the square and the sum of three
// round five times at most (relative 5 * 2^-53); 2^-50 is eight of those.
inline constexpr double kBoxSlack = 1.0 - 0x1p-50;

struct PointEntry {
    uint32_t child, count;
    double key;  // lower bound of the squared distance to the child's box
};

class NearestQuery {
public:
    using Entry = PointEntry;
    using Bound = double;  // the squared distance within which a triangle may still be the nearest
    static constexpr int kStackCapacity = queries::kStackSize * 4;  // at most seven pushes per level

    NearestQuery(const WideLayout<8>& wide, const Vec3d& p) : nodes_(wide.nodes.data()) {
        for (int a = 0; a < 3; ++a) {
            const double c = p[size_t(a)];
            p_[a] = Double8{c, c, c, c, c, c, c, c};
        }
    }
    Entry root() const { return {0, 0, 0.0}; }
    static bool is_leaf(const Entry& e) { return e.count != 0; }
    static bool beyond(const Entry& e, Bound bound) { return e.key > bound; }

    [[gnu::always_inline]] int enter(Entry& entry, Bound bound, Entry* out) const {
        const WideNode<8>& node = nodes_[entry.child];
        Double8 d2 = {};
        Mask8 used = {};
        for (int a = 0; a < 3; ++a) {
            Float8 lo_f, hi_f;
            __builtin_memcpy(&lo_f, node.planes[2 * a], sizeof lo_f);
            __builtin_memcpy(&hi_f, node.planes[2 * a + 1], sizeof hi_f);
            const Double8 lo = __builtin_convertvector(lo_f, Double8), hi = __builtin_convertvector(hi_f, Double8);
            if (a == 0) used = lo <= hi;  // unused slots hold empty boxes
            const Double8 below = lo - p_[a], above = p_[a] - hi;
            Double8 gap = below > above ? below : above;
            gap = gap > 0.0 ? gap : Double8{};
            d2 += gap * gap;
        }
        alignas(64) double key[8];
        const Double8 lower = d2 * kBoxSlack;
        const Mask8 within = (lower <= bound) & used;
        __builtin_memcpy(key, &lower, sizeof key);
        unsigned entered = 0;
        for (int slot = 0; slot < 8; ++slot)
            if (within[slot]) entered |= 1u << slot;
        if (entered == 0) return 0;
        const int n = nearest_first(entered, key, entry, out, [&](int slot) {
            return Entry{node.child[slot], node.count[slot], key[slot]};
        });
        if (entry.count == 0) __builtin_prefetch(&nodes_[entry.child]);
        return n;
    }

private:
    const WideNode<8>* nodes_;
    Double8 p_[3];
};

typedef double Double4 __attribute__((vector_size(32)));
typedef float Float4 __attribute__((vector_size(16)));
typedef long long Mask4 __attribute__((vector_size(32)));

// The lanes of a pack whose triangle's bounding box lies within `bound` (squared) of p: the box's
// squared distance in double, scaled down as the nodes' (kBoxSlack), a lower bound of the triangle's.
[[gnu::always_inline]] inline unsigned near_lanes(const TrianglePack& pack, const Vec3d& p, double bound) {
    Double4 d2 = {};
    for (int a = 0; a < 3; ++a) {
        Float4 v0, v1, v2;
        __builtin_memcpy(&v0, pack.vertex[0][a], sizeof v0);
        __builtin_memcpy(&v1, pack.vertex[1][a], sizeof v1);
        __builtin_memcpy(&v2, pack.vertex[2][a], sizeof v2);
        Float4 lo = v0 < v1 ? v0 : v1, hi = v0 < v1 ? v1 : v0;
        lo = lo < v2 ? lo : v2;
        hi = hi < v2 ? v2 : hi;
        const double c = p[size_t(a)];
        const Double4 below = __builtin_convertvector(lo, Double4) - c,
                      above = c - __builtin_convertvector(hi, Double4);
        Double4 gap = below > above ? below : above;
        gap = gap > 0.0 ? gap : Double4{};
        d2 += gap * gap;
    }
    const Mask4 within = d2 * kBoxSlack <= bound;
    unsigned lanes = 0;
    for (int l = 0; l < 4; ++l)
        if (within[l]) lanes |= 1u << l;
    return lanes;
}

D3 d3(const Vec3& v) { return {double(v.x), double(v.y), double(v.z)}; }

bool same_point(D3 a, D3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

// The end points of a candidate's certified edge.
void edge_ends(const Triangle& t, uint8_t feature, D3& a, D3& b) {
    const int first = feature == kEdge01 ? 0 : feature == kEdge12 ? 1 : 2;
    a = d3(t.vertex(first));
    b = d3(t.vertex((first + 1) % 3));
}

// Whether every candidate is certified on one and the same vertex or edge: then all lie at exactly
// the same distance.
bool same_certified_feature(std::span<const Candidate> candidates, std::span<const Triangle> triangles) {
    const Candidate& first = candidates[0];
    if (first.at.certified == Certified::none) return false;
    D3 a0{}, b0{};
    if (first.at.certified == Certified::edge) edge_ends(triangles[first.primitive], first.at.feature, a0, b0);
    for (const Candidate& c : candidates.subspan(1)) {
        if (c.at.certified != first.at.certified) return false;
        if (c.at.certified == Certified::vertex) {
            if (!same_point(c.at.point, first.at.point)) return false;
        } else {
            D3 a, b;
            edge_ends(triangles[c.primitive], c.at.feature, a, b);
            if (!((same_point(a, a0) && same_point(b, b0)) || (same_point(a, b0) && same_point(b, a0)))) return false;
        }
    }
    return true;
}

// The nearest of candidates that the double bounds cannot tell apart, ties to the smaller id.
const Candidate& decide(std::span<const Candidate> candidates, std::span<const Triangle> triangles, D3 p) {
    const Candidate* best = &candidates[0];
    if (same_certified_feature(candidates, triangles)) {
        for (const Candidate& c : candidates)
            if (c.primitive < best->primitive) best = &c;
        return *best;
    }
    const auto exact = [&](const Candidate& c) {
        const Triangle& t = triangles[c.primitive];
        return exact_squared_distance(p, t.v0, t.v1, t.v2);
    };
    ExactSquaredDistance best_d2 = exact(*best);
    for (const Candidate& c : candidates.subspan(1)) {
        const ExactSquaredDistance d2 = exact(c);
        const int order = compare(d2, best_d2);
        if (order < 0 || (order == 0 && c.primitive < best->primitive)) {
            best = &c;
            best_d2 = d2;
        }
    }
    return *best;
}

// Whether the winner lies within max_distance: by the double bound where it tells, else exactly.
bool within(const Candidate& c, const Triangle& t, D3 p, double max_distance) {
    if (std::isinf(max_distance)) return true;
    const double limit = max_distance * max_distance;  // rounded: the slack below covers it
    if (c.at.d2 + c.at.error < limit * (1.0 - 0x1p-50)) return true;
    if (c.at.d2 - c.at.error > limit * (1.0 + 0x1p-50)) return false;
    return compare(exact_squared_distance(p, t.v0, t.v1, t.v2), max_distance) <= 0;
}

}  // namespace

std::vector<TriangleConditioning> pack_conditioning(const WideLayout<8>& wide) {
    std::vector<TriangleConditioning> out(wide.packs.size() * 4);
    for (size_t i = 0; i < wide.packs.size(); ++i)
        for (int l = 0; l < 4; ++l) {
            const TrianglePack& pack = wide.packs[i];
            const auto vertex = [&](int v) {
                return D3{pack.vertex[v][0][l], pack.vertex[v][1][l], pack.vertex[v][2][l]};
            };
            out[4 * i + size_t(l)] = conditioning(vertex(0), vertex(1), vertex(2));
        }
    return out;
}

ClosestPoint nearest_triangle(const WideLayout<8>& wide, std::span<const TriangleConditioning> conditioning,
                              std::span<const Triangle> triangles, const Vec3d& point, double max_distance,
                              std::vector<Candidate>& candidates) {
    ClosestPoint result;
    if (wide.nodes.empty()) return result;
    const D3 p{point[0], point[1], point[2]};
    // The bound of the walk: the least upper bound of a candidate's squared distance so far.
    double bound = std::isinf(max_distance) ? std::numeric_limits<double>::infinity()
                                            : max_distance * max_distance * (1.0 + 0x1p-50);
    candidates.clear();
    const TrianglePack* packs = wide.packs.data();
    const NearestQuery query(wide, point);
    walk(query, bound, [&](const PointEntry& leaf) {
        for (uint32_t first = 0; first < leaf.count; first += 4) {
            const uint32_t index = leaf.child + first / 4;
            const TrianglePack& pack = packs[index];
            // The lanes whose triangle's box lies within the bound (a lower bound, as the nodes').
            const unsigned lanes = near_lanes(pack, point, bound) & ((1u << std::min(4u, leaf.count - first)) - 1u);
            for (unsigned m = lanes; m; m &= m - 1) {
                const int l = __builtin_ctz(m);
                const D3 a{pack.vertex[0][0][l], pack.vertex[0][1][l], pack.vertex[0][2][l]};
                const D3 b{pack.vertex[1][0][l], pack.vertex[1][1][l], pack.vertex[1][2][l]};
                const D3 c{pack.vertex[2][0][l], pack.vertex[2][1][l], pack.vertex[2][2][l]};
                const PointTriangle at = closest_on_triangle(p, a, b, c, conditioning[4 * size_t(index) + size_t(l)]);
                if (at.d2 - at.error > bound) continue;
                candidates.push_back({pack.primitive[l], at});
                bound = std::min(bound, at.d2 + at.error);
            }
        }
        return false;
    });
    // The candidates still within the final bound, each triangle once (a clipped triangle may sit in
    // several leaves).
    std::erase_if(candidates, [&](const Candidate& c) { return c.at.d2 - c.at.error > bound; });
    if (candidates.empty()) return result;
    std::sort(candidates.begin(), candidates.end(),
              [](const Candidate& x, const Candidate& y) { return x.primitive < y.primitive; });
    candidates.erase(std::unique(candidates.begin(), candidates.end(),
                                 [](const Candidate& x, const Candidate& y) { return x.primitive == y.primitive; }),
                     candidates.end());
    const Candidate& best = candidates.size() == 1 ? candidates[0] : decide(candidates, triangles, p);
    if (!within(best, triangles[best.primitive], p, max_distance)) return result;
    result.primitive = best.primitive;
    result.point = {best.at.point.x, best.at.point.y, best.at.point.z};
    result.distance = std::sqrt(best.at.d2);
    result.u = best.at.u;
    result.v = best.at.v;
    result.feature = best.at.feature;
    return result;
}

}  // namespace spacebvh::trace::distance
