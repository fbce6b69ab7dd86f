// SPDX-License-Identifier: MIT
// Generalized winding numbers (Jacobson, Kavan and Sorkine-Hornung 2013): the direct sum of the
// triangles' signed solid angles with its error bound, and Barill et al.'s hierarchical
// approximation (2018) over the tree's nodes, to Taylor order 0, 1 or 2 with a bound on its
// truncation error (docs/distance.md).
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "trace/distance/point_triangle.hpp"

namespace spacebvh::trace::distance {

// The signed solid angle of one triangle seen from p (Van Oosterom and Strackee 1983) and a bound
// on its error.
std::pair<double, double> solid_angle(D3 p, const Triangle& t);

// The highest Taylor order of the far-field expansion (the dipole is order 0).
inline constexpr int kMaxWindingOrder = 2;

// A node of the tree with what the far-field expansion needs, about the area-weighted centroid c of
// the node's triangles: the largest distance from c to their vertices, the sum of their unsigned
// areas, and the moments of their area vectors a_t (half the cross products): order 0 the sum of the
// a_t; order 1 first[i][j] = sum a_t,i (centroid_t - c)_j; order 2 second[i][m] = sum a_t,i M_t,m
// with M_t the triangle's second moment about c over its area, integral (x - c)(x - c)^T dA / area_t,
// its six entries xx yy zz xy xz yz. Triangles [first, first + count) of `order`.
struct WindingNode {
    D3 center{}, area{};
    double radius = 0.0, unsigned_area = 0.0;
    double first_moment[3][3] = {};
    double second_moment[3][6] = {};
    uint32_t first = 0, count = 0;
    uint32_t child[2] = {0, 0};
    bool leaf = false;
};

class WindingTree {
public:
    WindingTree() = default;
    // Each non-degenerate triangle once, in the first leaf (depth first) that holds it.
    WindingTree(std::span<const Triangle> triangles, const Bvh& bvh);

    // The direct sum over every triangle, in id order, and its error bound.
    std::pair<double, double> direct(std::span<const Triangle> triangles, D3 p) const;
    // The hierarchical approximation and a bound on its error: a node beyond accuracy times its radius
    // counts as its expansion to Taylor order `order` (0 to kMaxWindingOrder), the others open.
    std::pair<double, double> hierarchical(std::span<const Triangle> triangles, D3 p, double accuracy, int order) const;

private:
    uint32_t add(std::span<const Triangle> triangles, const Bvh& bvh, uint32_t index, std::vector<uint8_t>& placed);
    void summarize(std::span<const Triangle> triangles, WindingNode& node) const;
    static void add_moments(const Triangle& t, WindingNode& node);

    std::vector<WindingNode> nodes_;  // nodes_[0] is the root, when there is one
    std::vector<uint32_t> order_;     // triangle ids, subtree by subtree
};

}  // namespace spacebvh::trace::distance
