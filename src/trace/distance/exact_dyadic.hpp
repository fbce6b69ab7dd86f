// SPDX-License-Identifier: MIT
// Exact arithmetic on dyadic rationals (m * 2^e, m an integer of any size): the exact decision of
// the nearest triangle (exact_distance.hpp). Every input of a distance query (a double point, float
// vertices) is dyadic, and the decision needs only sums, differences and products of inputs, so no
// division and no rounding: values are held as sign, magnitude (32-bit limbs) and exponent.
#pragma once

#include <cstdint>
#include <vector>

namespace spacebvh::trace::distance {

class Dyadic {
public:
    Dyadic() = default;
    explicit Dyadic(double value);  // exact; value must be finite

    friend Dyadic operator+(const Dyadic& a, const Dyadic& b);
    friend Dyadic operator-(const Dyadic& a, const Dyadic& b);
    friend Dyadic operator*(const Dyadic& a, const Dyadic& b);
    Dyadic operator-() const {
        Dyadic r = *this;
        r.sign_ = -r.sign_;
        return r;
    }
    int sign() const { return sign_; }

private:
    // Adds (sign_b = +1) or subtracts (-1) b.
    static Dyadic combine(const Dyadic& a, const Dyadic& b, int sign_b);

    int sign_ = 0;                // -1, 0 or 1; the magnitude is empty when 0
    std::vector<uint32_t> limbs;  // magnitude, least significant limb first, no leading zero limb
    int64_t exponent = 0;         // value = sign * magnitude * 2^exponent
};

// The sign of a - b.
inline int compare(const Dyadic& a, const Dyadic& b) { return (a - b).sign(); }

}  // namespace spacebvh::trace::distance
