// SPDX-License-Identifier: MIT
// The subdivided box of the query tests: exact coordinates, so that rays and points through its
// vertices, edges and faces are hostile and still exactly representable.
#pragma once

#include <utility>
#include <vector>

#include "spacebvh/geometry.hpp"

namespace spacebvh {

// A closed, consistently oriented box of n x n quads per face with integer coordinates in [0, 2n]:
// rays through its vertices and edge midpoints from half-integer points are exact.
inline std::vector<Triangle> grid_box(int n) {
    std::vector<Triangle> out;
    const float size = float(2 * n);
    for (int axis = 0; axis < 3; ++axis) {
        for (int side = 0; side < 2; ++side) {
            const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
            for (int i = 0; i < n; ++i) {
                for (int j = 0; j < n; ++j) {
                    auto corner = [&](int di, int dj) {
                        Vec3 p;
                        p[axis] = side ? size : 0.0f;
                        p[a1] = float(2 * (i + di));
                        p[a2] = float(2 * (j + dj));
                        return p;
                    };
                    Vec3 a = corner(0, 0), b = corner(1, 0), c = corner(1, 1), d = corner(0, 1);
                    // Outward winding: (a1, a2, axis) is right-handed, so a -> b -> c faces +axis.
                    if (side == 0) std::swap(b, d);
                    out.push_back({a, b, c});
                    out.push_back({a, c, d});
                }
            }
        }
    }
    return out;
}

}  // namespace spacebvh
