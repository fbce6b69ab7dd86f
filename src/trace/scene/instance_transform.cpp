// SPDX-License-Identifier: MIT
// Instance transforms: validation, the float inverse, the placed box and its padding (the bound is
// derived in docs/scenes.md, "Boxes of instances").
#include "trace/scene/instance_transform.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <string>

#include "spacebvh/error.hpp"

namespace spacebvh {

Affine Affine::from_4x4(std::span<const float, 16> rows) {
    if (rows[12] != 0.0f || rows[13] != 0.0f || rows[14] != 0.0f || rows[15] != 1.0f) {
        std::ostringstream message;
        message << "transform: the last row of a 4x4 must be (0, 0, 0, 1), got (" << rows[12] << ", " << rows[13]
                << ", " << rows[14] << ", " << rows[15] << ")";
        throw Error(message.str());
    }
    Affine affine;
    for (int i = 0; i < 12; ++i) affine.m[i] = rows[i];
    return affine;
}

Vec3 Affine::apply(Vec3 p) const {
    Vec3 out;
    for (int i = 0; i < 3; ++i)
        out[i] = float(double(m[4 * i]) * p.x + double(m[4 * i + 1]) * p.y + double(m[4 * i + 2]) * p.z +
                       double(m[4 * i + 3]));
    return out;
}

namespace scene {
namespace {

using Matrix = std::array<double, 9>;

// The inverse of a 3x3 matrix by its adjugate; `det` receives the determinant.
Matrix inverse_of(const Matrix& a, double& det) {
    const Matrix adj{a[4] * a[8] - a[5] * a[7], a[2] * a[7] - a[1] * a[8], a[1] * a[5] - a[2] * a[4],
                     a[5] * a[6] - a[3] * a[8], a[0] * a[8] - a[2] * a[6], a[2] * a[3] - a[0] * a[5],
                     a[3] * a[7] - a[4] * a[6], a[1] * a[6] - a[0] * a[7], a[0] * a[4] - a[1] * a[3]};
    det = a[0] * adj[0] + a[1] * adj[3] + a[2] * adj[6];
    Matrix inv;
    for (int i = 0; i < 9; ++i) inv[i] = adj[i] / det;
    return inv;
}

double norm_inf(const Matrix& a) {
    double best = 0.0;
    for (int r = 0; r < 3; ++r)
        best = std::max(best, std::fabs(a[3 * r]) + std::fabs(a[3 * r + 1]) + std::fabs(a[3 * r + 2]));
    return best;
}

double max_abs(const AABB& box) {
    double m = 0.0;
    for (int i = 0; i < 3; ++i) m = std::max({m, std::fabs(double(box.lo[i])), std::fabs(double(box.hi[i]))});
    return m;
}

// std::nextafter(f, up ? +inf : -inf), inline for finite f (the library call costs more than the
// rest of a box's rounding): one step of the bits away from or towards zero.
float next_float(float f, bool up) {
    if (!std::isfinite(f)) return std::nextafter(f, up ? INFINITY : -INFINITY);
    if (f == 0.0f) return up ? std::numeric_limits<float>::denorm_min() : -std::numeric_limits<float>::denorm_min();
    const uint32_t bits = std::bit_cast<uint32_t>(f);
    return std::bit_cast<float>((f > 0.0f) == up ? bits + 1 : bits - 1);
}

// The exact inverse (in double) of the float inverse: the map from the instance's space back to the
// parent's that the padding bound is stated for.
Matrix back_of(const InstanceTransform& xf) {
    Matrix ai;
    for (int i = 0; i < 9; ++i) ai[i] = xf.inverse[i];
    double det = 0.0;
    return inverse_of(ai, det);
}

}  // namespace

void place_box(InstanceTransform& xf, const AABB& child_box, Padding child) {
    const Matrix back = back_of(xf);
    Matrix ai;
    for (int i = 0; i < 9; ++i) ai[i] = xf.inverse[i];
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int corner = 0; corner < 8; ++corner) {
        const double p[3] = {double((corner & 1) ? child_box.hi.x : child_box.lo.x) - xf.inverse_shift[0],
                             double((corner & 2) ? child_box.hi.y : child_box.lo.y) - xf.inverse_shift[1],
                             double((corner & 4) ? child_box.hi.z : child_box.lo.z) - xf.inverse_shift[2]};
        for (int i = 0; i < 3; ++i) {
            const double w = back[3 * i] * p[0] + back[3 * i + 1] * p[1] + back[3 * i + 2] * p[2];
            lo[i] = std::min(lo[i], w);
            hi[i] = std::max(hi[i], w);
        }
    }
    for (int i = 0; i < 3; ++i) {
        xf.box.lo[i] = next_float(float(lo[i]), false);
        xf.box.hi[i] = next_float(float(hi[i]), true);
    }
    // docs/scenes.md: the child's own allowance carried through the map, plus the rounding of the ray
    // transform (u = 2^-23 covers the double sums and the one rounding to float) at any t where the
    // ray is near the box (there |t dir| <= 2 (|org| + R)), with margins for the double arithmetic.
    constexpr double u = 0x1p-23;
    const double nb = norm_inf(back), ni = norm_inf(ai);
    const double shift = std::max({std::fabs(double(xf.inverse_shift[0])), std::fabs(double(xf.inverse_shift[1])),
                                   std::fabs(double(xf.inverse_shift[2]))});
    const double r = max_abs(xf.box);
    const double c0 = child.pad0 + 0x1p-29 * max_abs(child_box), c1 = child.pad1 + 0x1p-29;
    xf.padding.pad0 = 1.01 * nb * (c0 + c1 * shift + u * (shift + 2.0 * ni * r));
    xf.padding.pad1 = 1.01 * nb * (c1 * ni + 3.0 * u * ni);
}

InstanceTransform make_instance_transform(const Affine& transform, const AABB& child_box, Padding child,
                                          const std::string& what) {
    for (int i = 0; i < 12; ++i)
        if (!std::isfinite(transform.m[i]))
            throw Error(what + ": transform entry (" + std::to_string(i / 4) + ", " + std::to_string(i % 4) +
                        ") is not finite");
    const Matrix a{transform.m[0], transform.m[1], transform.m[2], transform.m[4], transform.m[5],
                   transform.m[6], transform.m[8], transform.m[9], transform.m[10]};
    double det = 0.0;
    const Matrix inv = inverse_of(a, det);
    if (det == 0.0 || !std::isfinite(det)) throw Error(what + ": transform is singular (determinant 0)");
    InstanceTransform xf;
    Matrix rounded;
    for (int i = 0; i < 9; ++i) rounded[i] = xf.inverse[i] = float(inv[i]);
    for (int i = 0; i < 3; ++i)
        xf.inverse_shift[i] =
            float(-(inv[3 * i] * transform.m[3] + inv[3 * i + 1] * transform.m[7] + inv[3 * i + 2] * transform.m[11]));
    bool finite = true;
    for (float x : xf.inverse) finite = finite && std::isfinite(x) && (x == 0.0f || std::fabs(x) >= 0x1p-126f);
    for (float x : xf.inverse_shift) finite = finite && std::isfinite(x);
    const double condition = norm_inf(a) * norm_inf(rounded);
    if (!finite || !(condition <= kMaxConditionNumber)) {
        std::ostringstream message;
        message << what << ": transform is nearly singular (condition number " << condition << ", at most "
                << kMaxConditionNumber << " accepted)";
        throw Error(message.str());
    }
    place_box(xf, child_box, child);
    return xf;
}

}  // namespace scene
}  // namespace spacebvh
