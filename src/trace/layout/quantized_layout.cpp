// SPDX-License-Identifier: MIT
#include "trace/layout/quantized_layout.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "spacebvh/error.hpp"
#include "trace/traversal/traversal_common.hpp"

namespace spacebvh::trace {
namespace {

// The grid of one axis: origin = the lowest lower bound (so code 0 decodes to at most every lower
// bound) and the smallest power-of-two scale, at least 2^-126 (a normal float), whose code 255 decodes
// to at least the highest upper bound. Scale 2^127 always does: 255 * 2^127 + origin overflows to +inf.
void choose_grid(float lowest, float highest, float& origin, float& scale) {
    origin = lowest;
    int exponent = -126;
    const double extent = double(highest) - double(lowest);
    if (extent > 0) exponent = std::clamp(int(std::ceil(std::log2(extent / 255.0))), -126, 127);
    while (exponent < 127 && decode_plane(255, std::ldexp(1.0f, exponent), origin) < highest) ++exponent;
    while (exponent > -126 && decode_plane(255, std::ldexp(1.0f, exponent - 1), origin) >= highest) --exponent;
    scale = std::ldexp(1.0f, exponent);
}

// The largest code whose plane is at most `lo` (code 0 qualifies: it decodes to the origin <= lo).
uint8_t lower_code(float lo, float origin, float scale) {
    int q = int(std::clamp(std::floor((double(lo) - double(origin)) / double(scale)), 0.0, 255.0));
    while (q > 0 && decode_plane(uint8_t(q), scale, origin) > lo) --q;
    while (q < 255 && decode_plane(uint8_t(q + 1), scale, origin) <= lo) ++q;
    return uint8_t(q);
}

// The smallest code whose plane is at least `hi` (code 255 qualifies, by choose_grid).
uint8_t upper_code(float hi, float origin, float scale) {
    int q = int(std::clamp(std::ceil((double(hi) - double(origin)) / double(scale)), 0.0, 255.0));
    while (q < 255 && decode_plane(uint8_t(q), scale, origin) < hi) ++q;
    while (q > 0 && decode_plane(uint8_t(q - 1), scale, origin) >= hi) --q;
    return uint8_t(q);
}

}  // namespace

QuantizedNode8 quantize_node(const WideNode<8>& node) {
    QuantizedNode8 out{};
    out.used_mask = 0;
    for (int slot = 0; slot < 8; ++slot) {
        if (!node.used(slot)) {
            // Never entered (used_mask); the codes of an inverted box only as a second guard.
            for (int axis = 0; axis < 3; ++axis) {
                out.q[2 * axis][slot] = 255;
                out.q[2 * axis + 1][slot] = 0;
            }
            out.child[slot] = 0;
            out.count[slot] = 0;
            continue;
        }
        if (node.count[slot] > 0xffffu)
            throw Error("quantized nodes: a leaf of " + std::to_string(node.count[slot]) +
                        " triangle lanes (at most 65535)");
        out.used_mask |= uint8_t(1u << slot);
        out.child[slot] = node.child[slot];
        out.count[slot] = uint16_t(node.count[slot]);
    }
    for (int axis = 0; axis < 3; ++axis) {
        float lowest = 0.0f, highest = 0.0f;
        bool any = false;
        for (int slot = 0; slot < 8; ++slot) {
            if (!out.used(slot)) continue;
            const float lo = node.planes[2 * axis][slot], hi = node.planes[2 * axis + 1][slot];
            lowest = any ? std::min(lowest, lo) : lo;
            highest = any ? std::max(highest, hi) : hi;
            any = true;
        }
        choose_grid(lowest, highest, out.origin[axis], out.scale[axis]);
        for (int slot = 0; slot < 8; ++slot) {
            if (!out.used(slot)) continue;
            const float lo = node.planes[2 * axis][slot], hi = node.planes[2 * axis + 1][slot];
            out.q[2 * axis][slot] = lower_code(lo, out.origin[axis], out.scale[axis]);
            out.q[2 * axis + 1][slot] = upper_code(hi, out.origin[axis], out.scale[axis]);
            // The invariant the kernels' exactness rests on (quantized_layout.hpp); it cannot fail for
            // finite boxes, and a box it would shrink must not be stored.
            if (!(decode_plane(out.q[2 * axis][slot], out.scale[axis], out.origin[axis]) <= lo &&
                  decode_plane(out.q[2 * axis + 1][slot], out.scale[axis], out.origin[axis]) >= hi))
                throw Error("quantized nodes: a child box cannot be rounded outward (non-finite bounds?)");
        }
    }
    return out;
}

QuantizedLayout8 quantize_wide(WideLayout<8>&& wide) {
    // The codes are chosen by decoding them, so decode as the kernels do: without flush-to-zero.
    const StandardFloatingPointMode mode;
    QuantizedLayout8 layout;
    layout.nodes.reserve(wide.nodes.size());
    for (const WideNode<8>& node : wide.nodes) layout.nodes.push_back(quantize_node(node));
    layout.packs = std::move(wide.packs);
    layout.planes = std::move(wide.planes);
    return layout;
}

AABB decoded_box(const QuantizedNode8& node, int slot) {
    AABB box;
    for (int axis = 0; axis < 3; ++axis) {
        box.lo[axis] = decode_plane(node.q[2 * axis][slot], node.scale[axis], node.origin[axis]);
        box.hi[axis] = decode_plane(node.q[2 * axis + 1][slot], node.scale[axis], node.origin[axis]);
    }
    return box;
}

}  // namespace spacebvh::trace
