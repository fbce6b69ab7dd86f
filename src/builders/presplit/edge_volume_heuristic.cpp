// SPDX-License-Identifier: MIT
// The edge volume heuristic (EVH): Dammertz & Keller, "The Edge Volume Heuristic - Robust Triangle
// Subdivision for Improved BVH Performance", IEEE/EG Symposium on Interactive Ray Tracing 2008.
//
// As in the paper: for a triangle, take the axis-aligned box of each of its three edges; if the
// largest edge-box volume exceeds eps_v = V_scene * 2^-t (V_scene = volume of the scene box,
// t = 14 by default), split the triangle at the midpoint of that edge into two triangles and recurse
// on both. The sub-triangles' boxes become references to the original triangle; the sub-triangles
// themselves are not kept. Edges are split symmetrically (only edges decide), so a shared edge is
// cut the same way in both its triangles. Ties between equal edge volumes go to the longest edge,
// then to the lower edge index.
//
// Exactness: a sub-triangle is kept as barycentric coordinates of the original triangle. Those are
// dyadic rationals (midpoints of midpoints) with at most 25 significant bits at depth <= 24, so they
// are exact in double; positions are evaluated in double and the box is rounded outward by more
// than the evaluation error, then clamped into the triangle's box. A reference box is thus the
// bounds of the actual part of the original triangle (not of a float-rounded midpoint triangle),
// widened by at most a few float ulps, and the sub-triangles tile the triangle, so their boxes cover it.
//
// Budget: the splits are done greedily, scene-wide, on the sub-triangle of largest edge volume first
// (detail::greedy_presplit), so when the heuristic wants more than floor(budget * n) references the
// worst-bounded edges win. (Dammertz & Keller count first, then generate; with a budget the global
// greedy order is what decides which splits survive.)
#include <array>
#include <cmath>

#include "builders/presplit/presplit.hpp"

namespace spacebvh::builders {
namespace {

using DVec = std::array<double, 3>;

class EvhPolicy {
public:
    struct Piece {
        // Barycentric weights (w0, w1, w2) of the three corners; w0 + w1 + w2 == 1 exactly.
        std::array<std::array<double, 3>, 3> corners;
    };

    EvhPolicy(std::span<const Triangle> triangles, float t) : triangles_(triangles) {
        const AABB box = bounds_of(triangles);
        const Vec3 e = box.extent();
        const double volume = box.is_empty() ? 0.0 : double(e.x) * double(e.y) * double(e.z);
        threshold_ = volume * std::exp2(-double(t));
        if (!(threshold_ >= 0.0)) threshold_ = kInfinity;  // NaN t: never split
    }

    double threshold() const { return threshold_; }
    Piece root(uint32_t) const { return {{{{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}}}}; }

    double priority(uint32_t triangle, const Piece& piece) const {
        const std::array<DVec, 3> p = positions(triangles_[triangle], piece);
        double best = 0.0;
        for (int i = 0; i < 3; ++i) best = std::max(best, edge_volume(p[i], p[(i + 1) % 3]));
        return best;
    }

    int split(uint32_t triangle, const Piece& piece, Piece out[2]) const {
        const std::array<DVec, 3> p = positions(triangles_[triangle], piece);
        // Edge i runs from corner i to corner (i + 1) % 3.
        int edge = 0;
        double best_volume = -1.0, best_length = -1.0;
        for (int i = 0; i < 3; ++i) {
            const double volume = edge_volume(p[i], p[(i + 1) % 3]);
            const double length = squared_length(p[i], p[(i + 1) % 3]);
            if (volume > best_volume || (volume == best_volume && length > best_length)) {
                edge = i;
                best_volume = volume;
                best_length = length;
            }
        }
        const int a = edge, b = (edge + 1) % 3, c = (edge + 2) % 3;
        std::array<double, 3> middle;
        for (int k = 0; k < 3; ++k) middle[k] = 0.5 * (piece.corners[a][k] + piece.corners[b][k]);  // exact
        if (middle == piece.corners[a] || middle == piece.corners[b]) return 0;
        out[0].corners = {piece.corners[a], middle, piece.corners[c]};
        out[1].corners = {middle, piece.corners[b], piece.corners[c]};
        return 2;
    }

    AABB bounds(uint32_t triangle, const Piece& piece) const {
        const Triangle& t = triangles_[triangle];
        const AABB limit = t.bounds();
        const std::array<DVec, 3> p = positions(t, piece);
        AABB box;
        for (int k = 0; k < 3; ++k) {
            // Each coordinate is w0*a + w1*b + w2*c: the products are exact, the two additions
            // round by at most 2^-53 of a magnitude <= |a| + |b| + |c| each. Widen by more.
            const double scale = std::abs(double(t.v0[k])) + std::abs(double(t.v1[k])) + std::abs(double(t.v2[k]));
            const double error = scale * 0x1.0p-50;
            const double lo = std::min({p[0][k], p[1][k], p[2][k]}) - error;
            const double hi = std::max({p[0][k], p[1][k], p[2][k]}) + error;
            box.lo[k] = std::clamp(round_down(lo), limit.lo[k], limit.hi[k]);
            box.hi[k] = std::clamp(round_up(hi), limit.lo[k], limit.hi[k]);
        }
        return box;
    }

private:
    static std::array<DVec, 3> positions(const Triangle& t, const Piece& piece) {
        std::array<DVec, 3> p;
        for (int i = 0; i < 3; ++i) {
            const auto& w = piece.corners[i];
            for (int k = 0; k < 3; ++k)
                p[i][k] = w[0] * double(t.v0[k]) + w[1] * double(t.v1[k]) + w[2] * double(t.v2[k]);
        }
        return p;
    }
    static double edge_volume(const DVec& a, const DVec& b) {
        return std::abs(a[0] - b[0]) * std::abs(a[1] - b[1]) * std::abs(a[2] - b[2]);
    }
    static double squared_length(const DVec& a, const DVec& b) {
        double sum = 0.0;
        for (int k = 0; k < 3; ++k) sum += (a[k] - b[k]) * (a[k] - b[k]);
        return sum;
    }
    static float round_down(double value) {
        float f = float(value);
        if (double(f) > value) f = std::nextafter(f, -kInfinity);
        return f;
    }
    static float round_up(double value) {
        float f = float(value);
        if (double(f) < value) f = std::nextafter(f, kInfinity);
        return f;
    }

    std::span<const Triangle> triangles_;
    double threshold_ = 0.0;
};

}  // namespace

std::vector<Reference> edge_volume_heuristic(std::span<const Triangle> triangles, const PresplitOptions& options) {
    const EvhPolicy policy(triangles, options.evh_threshold);
    return detail::greedy_presplit(triangles, options, policy);
}

}  // namespace spacebvh::builders
