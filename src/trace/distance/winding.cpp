// SPDX-License-Identifier: MIT
#include "trace/distance/winding.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace spacebvh::trace::distance {

namespace {

constexpr double kEps = 0x1p-53;
constexpr double kFourPi = 4.0 * std::numbers::pi;

D3 d3(const Vec3& v) { return {double(v.x), double(v.y), double(v.z)}; }
double norm(D3 a) { return std::sqrt(dot(a, a)); }
D3 absolute(D3 a) { return {std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)}; }

}  // namespace

// Omega = 2 atan2(det, den), det = a . (b x c), den = |a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|, with
// a, b, c the vertices less p. Each of det and den is a sum of products of rounded differences whose
// error is within 2^-48 of the sum of the products' magnitudes (as kDotSlack); atan2's error from
// errors e_det, e_den of its arguments is at most (e_det + e_den) / hypot(det, den) while that is
// below a quarter (the argument then stays within its quadrant's neighbourhood), and atan2 itself
// rounds within a few units. Past that, or where det = den = 0 (p on the triangle), the bound is the
// trivial 4 pi or infinity.
std::pair<double, double> solid_angle(D3 p, const Triangle& t) {
    const D3 a = sub(d3(t.v0), p), b = sub(d3(t.v1), p), c = sub(d3(t.v2), p);
    const double la = norm(a), lb = norm(b), lc = norm(c);
    const double det = dot(a, cross(b, c));
    const double det_magnitude =
        dot(absolute(a), {std::fabs(b.y * c.z) + std::fabs(b.z * c.y), std::fabs(b.z * c.x) + std::fabs(b.x * c.z),
                          std::fabs(b.x * c.y) + std::fabs(b.y * c.x)});
    const double ab = dot(a, b), ac = dot(a, c), bc = dot(b, c);
    const double den = la * lb * lc + ab * lc + ac * lb + bc * la;
    const double den_magnitude =
        la * lb * lc + dot_magnitude(a, b) * lc + dot_magnitude(a, c) * lb + dot_magnitude(b, c) * la;
    const double omega = 2.0 * std::atan2(det, den);
    const double r = std::hypot(det, den);
    const double error = 0x1p-48 * (det_magnitude + den_magnitude);
    if (r == 0.0) return {omega, std::numeric_limits<double>::infinity()};
    if (error > 0.25 * r) return {omega, kFourPi};
    return {omega, 2.0 * (2.0 * error / r + 16.0 * kEps)};
}

WindingTree::WindingTree(std::span<const Triangle> triangles, const Bvh& bvh) {
    if (bvh.empty() || triangles.empty()) return;
    std::vector<uint8_t> placed(triangles.size(), 0);
    nodes_.reserve(bvh.nodes.size());
    add(triangles, bvh, 0, placed);
}

uint32_t WindingTree::add(std::span<const Triangle> triangles, const Bvh& bvh, uint32_t index,
                          std::vector<uint8_t>& placed) {
    const uint32_t at = uint32_t(nodes_.size());
    nodes_.emplace_back();
    const BvhNode& source = bvh.nodes[index];
    const uint32_t first = uint32_t(order_.size());
    if (source.is_leaf()) {
        for (uint32_t i = source.first; i < source.first + source.reference_count; ++i) {
            const uint32_t id = bvh.primitives[i];
            if (placed[id] || triangles[id].is_degenerate()) continue;
            placed[id] = 1;
            order_.push_back(id);
        }
        nodes_[at].leaf = true;
    } else {
        // Recursion depth: the tree was accepted by RayQueries' layout (at most kStackSize / 2 levels).
        const uint32_t left = add(triangles, bvh, source.first, placed);
        const uint32_t right = add(triangles, bvh, source.first + 1, placed);
        nodes_[at].child[0] = left;
        nodes_[at].child[1] = right;
    }
    nodes_[at].first = first;
    nodes_[at].count = uint32_t(order_.size()) - first;
    summarize(triangles, nodes_[at]);
    return at;
}

void WindingTree::summarize(std::span<const Triangle> triangles, WindingNode& node) const {
    double weight = 0.0;
    D3 center{0, 0, 0}, area{0, 0, 0}, mean{0, 0, 0};
    for (uint32_t k = node.first; k < node.first + node.count; ++k) {
        const Triangle& t = triangles[order_[k]];
        const D3 a = d3(t.v0), b = d3(t.v1), c = d3(t.v2);
        const D3 n = cross(sub(b, a), sub(c, a));
        const double w = 0.5 * norm(n);
        area = axpy(area, 0.5, n);
        const D3 centroid{(a.x + b.x + c.x) / 3.0, (a.y + b.y + c.y) / 3.0, (a.z + b.z + c.z) / 3.0};
        center = axpy(center, w, centroid);
        mean = axpy(mean, 1.0 / node.count, centroid);
        weight += w;
    }
    node.center = weight > 0.0 ? D3{center.x / weight, center.y / weight, center.z / weight} : mean;
    node.area = area;
    node.unsigned_area = weight;
    double radius = 0.0;
    for (uint32_t k = node.first; k < node.first + node.count; ++k) {
        const Triangle& t = triangles[order_[k]];
        for (int v = 0; v < 3; ++v) radius = std::max(radius, norm(sub(d3(t.vertex(v)), node.center)));
        add_moments(t, node);
    }
    // Grown by far more than the rounding of the norms, so that every point of the triangles lies
    // within it, as the truncation bound needs.
    node.radius = radius * (1.0 + 0x1p-40);
}

// One triangle's area vector a, times its centroid's offset from the node's centre (order 1), and
// times its second moment about the centre over its area (order 2): with d_v = v - c and
// s = d_0 + d_1 + d_2, integral (x - c)(x - c)^T dA = area (sum d_v d_v^T + s s^T) / 12.
void WindingTree::add_moments(const Triangle& t, WindingNode& node) {
    const D3 d[3] = {sub(d3(t.v0), node.center), sub(d3(t.v1), node.center), sub(d3(t.v2), node.center)};
    const D3 a = [&] {
        const D3 n = cross(sub(d[1], d[0]), sub(d[2], d[0]));
        return D3{0.5 * n.x, 0.5 * n.y, 0.5 * n.z};
    }();
    const double s[3] = {d[0].x + d[1].x + d[2].x, d[0].y + d[1].y + d[2].y, d[0].z + d[1].z + d[2].z};
    const double av[3] = {a.x, a.y, a.z};
    // The second moment over the area, entries xx yy zz xy xz yz.
    static constexpr int kRow[6] = {0, 1, 2, 0, 0, 1}, kColumn[6] = {0, 1, 2, 1, 2, 2};
    double moment[6];
    for (int m = 0; m < 6; ++m) {
        double sum = s[kRow[m]] * s[kColumn[m]];
        for (const D3& v : d) {
            const double w[3] = {v.x, v.y, v.z};
            sum += w[kRow[m]] * w[kColumn[m]];
        }
        moment[m] = sum / 12.0;
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) node.first_moment[i][j] += av[i] * s[j] / 3.0;
        for (int m = 0; m < 6; ++m) node.second_moment[i][m] += av[i] * moment[m];
    }
}

std::pair<double, double> WindingTree::direct(std::span<const Triangle> triangles, D3 p) const {
    double sum = 0.0, bound = 0.0, magnitude = 0.0;
    for (const Triangle& t : triangles) {
        if (t.is_degenerate()) continue;
        const auto [omega, error] = solid_angle(p, t);
        sum += omega;
        bound += error;
        magnitude += std::fabs(omega);
    }
    // The running sum rounds once per term: within n eps of the sum of magnitudes (Higham's gamma_n).
    const double n = double(triangles.size());
    bound += 1.01 * n * kEps * magnitude;
    const double w = sum / kFourPi;
    return {w, bound / kFourPi * (1.0 + 4.0 * kEps) + 4.0 * kEps * std::fabs(w)};
}

namespace {

// The node's far-field expansion seen from p, r = c - p, |r| = d: the integral over its triangles of
// n . (x - p) / |x - p|^3 with the kernel g(x) = (x - p) / |x - p|^3 replaced by its Taylor polynomial
// about c of degree `order`. With the first derivatives dg_i/dx_j = delta_ij / d^3 - 3 r_i r_j / d^5 and
// the second d2g_i/dx_j dx_k = -3 (delta_ik r_j + delta_ij r_k + delta_jk r_i) / d^5 + 15 r_i r_j r_k / d^7,
// the terms are r.A / d^3, sum_ij dg_i/dx_j first[i][j], and half of sum_ijk d2g_i/dx_j dx_k second[i][jk].
double expansion(const WindingNode& node, D3 r, double d, int order) {
    const double d2 = d * d, d3 = d2 * d;
    double sum = dot(r, node.area) / d3;
    if (order < 1) return sum;
    const double rv[3] = {r.x, r.y, r.z};
    const auto& f = node.first_moment;
    double trace = 0.0, quadratic = 0.0;
    for (int i = 0; i < 3; ++i) {
        trace += f[i][i];
        for (int j = 0; j < 3; ++j) quadratic += rv[i] * f[i][j] * rv[j];
    }
    const double d5 = d3 * d2;
    sum += trace / d3 - 3.0 * quadratic / d5;
    if (order < 2) return sum;
    const auto& m = node.second_moment;
    // sum_k T_iik r_k (row i of the symmetric moment times r), sum_j T_ijj, and r^T T_i r, for each i.
    double row_term = 0.0, trace_term = 0.0, cubic = 0.0;
    for (int i = 0; i < 3; ++i) {
        const double* t = m[i];  // xx yy zz xy xz yz
        const double row[3][3] = {{t[0], t[3], t[4]}, {t[3], t[1], t[5]}, {t[4], t[5], t[2]}};
        for (int k = 0; k < 3; ++k) row_term += row[i][k] * rv[k];
        trace_term += rv[i] * (t[0] + t[1] + t[2]);
        const double form = t[0] * r.x * r.x + t[1] * r.y * r.y + t[2] * r.z * r.z +
                            2.0 * (t[3] * r.x * r.y + t[4] * r.x * r.z + t[5] * r.y * r.z);
        cubic += rv[i] * form;
    }
    sum += 0.5 * (-3.0 * (2.0 * row_term + trace_term) / d5 + 15.0 * cubic / (d5 * d2));
    return sum;
}

// A bound on |expansion - exact| for the node: with psi(x) = 1 / |x - p| = sum_l H_l(x - c), H_l the
// degree-l term (|H_l(h)| = |h|^l |P_l(cos)| / d^(l+1)), the kernel is -grad psi and its Taylor
// polynomial of degree `order` is -sum_{l <= order + 1} grad H_l. By the Legendre inequality
// P_l^2 + (1 - x^2) P_l'^2 / (l (l + 1)) <= 1, |grad H_l(h)| <= (l + 1) |h|^(l - 1) / d^(l + 1); every
// point of the node's triangles has |h| <= radius = t d, so the remainder is at most
// sum_{l >= L} (l + 1) t^(l - 1) / d^2 = t^(L - 1) ((L + 1) - L t) / ((1 - t)^2 d^2), L = order + 2,
// times the node's unsigned area. Infinite where t >= 1 (the series need not converge).
double truncation_bound(const WindingNode& node, double d, int order) {
    const double t = node.radius / d;
    if (!(t < 1.0)) return std::numeric_limits<double>::infinity();
    const double L = order + 2;
    return node.unsigned_area * std::pow(t, L - 1.0) * ((L + 1.0) - L * t) / ((1.0 - t) * (1.0 - t) * d * d);
}

// A bound on the rounding of a node's expansion. Each moment is a sum over the node's triangles, within
// count + 64 units (2^-53 each, taken as 2^-50) of the sum of its terms' magnitudes, which is at most
// U (t d)^k for order k (U the unsigned area, t = radius / d; |area vector| <= area, |x - c| <= radius).
// By the formulas of expansion(), the terms are then at most U / d^2 times 1, 12 t (3 + 9) and 63 t^2
// (1.5 (2 * 3 sqrt 3 + 3 sqrt 3) + 7.5 * 3 sqrt 3), and their evaluation adds a few dozen roundings of
// those; the coefficients 64 and 256 cover both with margin.
double rounding_bound(const WindingNode& node, double d) {
    const double t = node.radius / d;
    return (node.count + 64.0) * 0x1p-50 * node.unsigned_area / (d * d) * (1.0 + 64.0 * t + 256.0 * t * t);
}

}  // namespace

std::pair<double, double> WindingTree::hierarchical(std::span<const Triangle> triangles, D3 p, double accuracy,
                                                    int order) const {
    if (nodes_.empty()) return {0.0, 0.0};
    double sum = 0.0, bound = 0.0, magnitude = 0.0, terms = 0.0;
    uint32_t stack[2 * 2048 + 2];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const WindingNode& node = nodes_[stack[--top]];
        if (node.count == 0) continue;
        const D3 r = sub(node.center, p);
        const double distance = norm(r);
        if (distance > accuracy * node.radius) {
            const double term = expansion(node, r, distance, order);
            sum += term;
            bound += truncation_bound(node, distance, order) + rounding_bound(node, distance);
            magnitude += std::fabs(term);
            terms += 1.0;
        } else if (node.leaf) {
            for (uint32_t k = node.first; k < node.first + node.count; ++k) {
                const auto [omega, error] = solid_angle(p, triangles[order_[k]]);
                sum += omega;
                bound += error;
                magnitude += std::fabs(omega);
                terms += 1.0;
            }
        } else {
            stack[top++] = node.child[1];
            stack[top++] = node.child[0];
        }
    }
    // The running sum rounds once per term, as the direct sum's.
    bound += 1.01 * terms * kEps * magnitude;
    const double w = sum / kFourPi;
    return {w, bound / kFourPi * (1.0 + 4.0 * kEps) + 4.0 * kEps * std::fabs(w)};
}

}  // namespace spacebvh::trace::distance
