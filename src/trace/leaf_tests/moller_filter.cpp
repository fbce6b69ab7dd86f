// SPDX-License-Identifier: MIT
#include "trace/leaf_tests/moller_filter.hpp"

#include <algorithm>
#include <cmath>

namespace spacebvh::trace {

PackPlanesList make_pack_planes(std::span<const TrianglePack> packs) {
    PackPlanesList planes(packs.size(), PackPlanes{});
    for (size_t p = 0; p < packs.size(); ++p) {
        const TrianglePack& pack = packs[p];
        for (int lane = 0; lane < 4; ++lane) {
            double e1[3], e2[3];
            for (int axis = 0; axis < 3; ++axis) {
                e1[axis] = double(pack.vertex[1][axis][lane]) - double(pack.vertex[0][axis][lane]);
                e2[axis] = double(pack.vertex[2][axis][lane]) - double(pack.vertex[0][axis][lane]);
            }
            // The normal from the exact (or nearly exact) double edges, rounded once to float: within
            // u |N| + 2^-49 m^2 of the exact normal per component (docs/leaf-test.md).
            const double normal[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                                      e1[0] * e2[1] - e1[1] * e2[0]};
            double scale = 0.0;
            for (int axis = 0; axis < 3; ++axis) {
                planes[p].normal[axis][lane] = float(normal[axis]);
                scale = std::max({scale, std::fabs(e1[axis]), std::fabs(e2[axis])});
            }
            // Rounded up, and a double edge is within 2^-53 of the exact one: m bounds the exact edges.
            const float rounded = float(scale * (1.0 + 0x1p-50));
            planes[p].edge_scale[lane] = double(rounded) >= scale * (1.0 + 0x1p-50)
                                             ? rounded
                                             : std::nextafter(rounded, std::numeric_limits<float>::infinity());
        }
    }
    return planes;
}

}  // namespace spacebvh::trace
