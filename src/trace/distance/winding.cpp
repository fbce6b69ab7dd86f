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
    double radius = 0.0;
    for (uint32_t k = node.first; k < node.first + node.count; ++k) {
        const Triangle& t = triangles[order_[k]];
        for (int v = 0; v < 3; ++v) radius = std::max(radius, norm(sub(d3(t.vertex(v)), node.center)));
    }
    node.radius = radius;
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

double WindingTree::hierarchical(std::span<const Triangle> triangles, D3 p, double accuracy) const {
    if (nodes_.empty()) return 0.0;
    double sum = 0.0;
    uint32_t stack[2 * 2048 + 2];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const WindingNode& node = nodes_[stack[--top]];
        if (node.count == 0) continue;
        const D3 r = sub(node.center, p);
        const double distance = norm(r);
        if (distance > accuracy * node.radius) {
            sum += dot(r, node.area) / (distance * distance * distance);
        } else if (node.leaf) {
            for (uint32_t k = node.first; k < node.first + node.count; ++k)
                sum += solid_angle(p, triangles[order_[k]]).first;
        } else {
            stack[top++] = node.child[1];
            stack[top++] = node.child[0];
        }
    }
    return sum / kFourPi;
}

}  // namespace spacebvh::trace::distance
