// SPDX-License-Identifier: MIT
#include "trace/distance/exact_dyadic.hpp"

#include <algorithm>
#include <cmath>

namespace spacebvh::trace::distance {

namespace {

using Limbs = std::vector<uint32_t>;

void trim(Limbs& x) {
    while (!x.empty() && x.back() == 0) x.pop_back();
}

// x * 2^shift (shift >= 0).
Limbs shifted(const Limbs& x, int64_t shift) {
    const size_t whole = size_t(shift / 32);
    const int bits = int(shift % 32);
    Limbs r(whole + x.size() + 1, 0);
    for (size_t i = 0; i < x.size(); ++i) {
        const uint64_t v = uint64_t(x[i]) << bits;
        r[whole + i] |= uint32_t(v);
        r[whole + i + 1] |= uint32_t(v >> 32);
    }
    trim(r);
    return r;
}

int compare_magnitude(const Limbs& a, const Limbs& b) {
    if (a.size() != b.size()) return a.size() < b.size() ? -1 : 1;
    for (size_t i = a.size(); i-- > 0;)
        if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
    return 0;
}

Limbs add_magnitude(const Limbs& a, const Limbs& b) {
    Limbs r(std::max(a.size(), b.size()) + 1, 0);
    uint64_t carry = 0;
    for (size_t i = 0; i + 1 < r.size(); ++i) {
        const uint64_t s = carry + (i < a.size() ? a[i] : 0u) + (i < b.size() ? b[i] : 0u);
        r[i] = uint32_t(s);
        carry = s >> 32;
    }
    r.back() = uint32_t(carry);
    trim(r);
    return r;
}

// a - b for a >= b.
Limbs subtract_magnitude(const Limbs& a, const Limbs& b) {
    Limbs r(a.size(), 0);
    int64_t borrow = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        int64_t d = int64_t(a[i]) - (i < b.size() ? int64_t(b[i]) : 0) - borrow;
        borrow = d < 0 ? 1 : 0;
        if (d < 0) d += int64_t(1) << 32;
        r[i] = uint32_t(d);
    }
    trim(r);
    return r;
}

}  // namespace

Dyadic::Dyadic(double value) {
    if (value == 0.0) return;
    int e;
    const double m = std::frexp(std::fabs(value), &e);  // |value| = m * 2^e, m in [0.5, 1)
    const uint64_t mantissa = uint64_t(std::ldexp(m, 53));
    sign_ = value < 0.0 ? -1 : 1;
    limbs = {uint32_t(mantissa), uint32_t(mantissa >> 32)};
    trim(limbs);
    exponent = int64_t(e) - 53;
}

Dyadic Dyadic::combine(const Dyadic& a, const Dyadic& b, int sign_b) {
    if (b.sign_ == 0) return a;
    if (a.sign_ == 0) {
        Dyadic r = b;
        r.sign_ *= sign_b;
        return r;
    }
    // Both magnitudes on the smaller exponent's grid.
    const int64_t e = std::min(a.exponent, b.exponent);
    const Limbs ma = shifted(a.limbs, a.exponent - e), mb = shifted(b.limbs, b.exponent - e);
    const int sa = a.sign_, sb = b.sign_ * sign_b;
    Dyadic r;
    r.exponent = e;
    if (sa == sb) {
        r.limbs = add_magnitude(ma, mb);
        r.sign_ = sa;
        return r;
    }
    const int c = compare_magnitude(ma, mb);
    if (c == 0) return Dyadic{};
    r.limbs = c > 0 ? subtract_magnitude(ma, mb) : subtract_magnitude(mb, ma);
    r.sign_ = c > 0 ? sa : sb;
    return r;
}

Dyadic operator+(const Dyadic& a, const Dyadic& b) { return Dyadic::combine(a, b, 1); }
Dyadic operator-(const Dyadic& a, const Dyadic& b) { return Dyadic::combine(a, b, -1); }

Dyadic operator*(const Dyadic& a, const Dyadic& b) {
    Dyadic r;
    if (a.sign_ == 0 || b.sign_ == 0) return r;
    r.limbs.assign(a.limbs.size() + b.limbs.size(), 0);
    for (size_t i = 0; i < a.limbs.size(); ++i) {
        uint64_t carry = 0;
        for (size_t j = 0; j < b.limbs.size(); ++j) {
            const uint64_t t = uint64_t(a.limbs[i]) * b.limbs[j] + r.limbs[i + j] + carry;
            r.limbs[i + j] = uint32_t(t);
            carry = t >> 32;
        }
        r.limbs[i + b.limbs.size()] = uint32_t(carry);
    }
    trim(r.limbs);
    r.sign_ = a.sign_ * b.sign_;
    r.exponent = a.exponent + b.exponent;
    return r;
}

}  // namespace spacebvh::trace::distance
