// SPDX-License-Identifier: MIT
// Generalized winding numbers (Jacobson, Kavan and Sorkine-Hornung 2013): the direct sum of the
// triangles' signed solid angles with its error bound, and Barill et al.'s hierarchical
// approximation (2018) over the tree's nodes, to first order (docs/distance.md).
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

// A node of the tree with what the far-field approximation needs: the area-weighted centroid of the
// node's triangles, the largest distance from it to their vertices, and the sum of their area
// vectors (half the cross products). Triangles [first, first + count) of `order`.
struct WindingNode {
    D3 center{}, area{};
    double radius = 0.0;
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
    // The hierarchical approximation: a node beyond accuracy times its radius counts as its dipole.
    double hierarchical(std::span<const Triangle> triangles, D3 p, double accuracy) const;

private:
    uint32_t add(std::span<const Triangle> triangles, const Bvh& bvh, uint32_t index, std::vector<uint8_t>& placed);
    void summarize(std::span<const Triangle> triangles, WindingNode& node) const;

    std::vector<WindingNode> nodes_;  // nodes_[0] is the root, when there is one
    std::vector<uint32_t> order_;     // triangle ids, subtree by subtree
};

}  // namespace spacebvh::trace::distance
