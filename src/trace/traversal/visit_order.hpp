// SPDX-License-Identifier: MIT
// The closest-hit order in which the single-ray wide kernels visit three or more children a ray
// enters, as integer keys that sort without branches. It is visits_after's order (wide_kernel.inl,
// which orders two children by comparing the floats), except that visits_after ties -0 with +0.
#pragma once

#include <cstdint>
#include <cstring>

namespace spacebvh::trace {

// One child's key: the entry distance's bits made order-preserving (negative distances flipped, so
// -0 sorts just below +0), then the slot reversed. Ascending keys are the visit order: nearest first;
// equal distances, the later slot first.
[[gnu::always_inline]] inline uint64_t visit_key(float entry, uint32_t slot) {
    uint32_t bits;
    std::memcpy(&bits, &entry, sizeof(bits));
    bits ^= (bits & 0x80000000u) ? 0xffffffffu : 0x80000000u;
    return (uint64_t(bits) << 32) | (0xffu - slot);
}

[[gnu::always_inline]] inline uint32_t visit_key_slot(uint64_t key) { return 0xffu - uint32_t(key & 0xffu); }

[[gnu::always_inline]] inline void order_keys(uint64_t& a, uint64_t& b) {
    const uint64_t low = a < b ? a : b, high = a < b ? b : a;
    a = low;
    b = high;
}

// Sorts n (3 <= n <= W) keys ascending. Up to four: the optimal five-exchange network, on the keys
// padded with the largest key (key must have room for four); more (8-wide nodes only, rare):
// insertion sort.
template <int W>
[[gnu::always_inline]] inline void sort_visit_keys(uint64_t* key, int n) {
    static_assert(W >= 4);
    if (n <= 4) {
        if (n == 3) key[3] = ~uint64_t(0);
        order_keys(key[0], key[1]);
        order_keys(key[2], key[3]);
        order_keys(key[0], key[2]);
        order_keys(key[1], key[3]);
        order_keys(key[1], key[2]);
        return;
    }
    for (int i = 1; i < n; ++i) {
        const uint64_t k = key[i];
        int j = i - 1;
        while (j >= 0 && key[j] > k) {
            key[j + 1] = key[j];
            --j;
        }
        key[j + 1] = k;
    }
}

}  // namespace spacebvh::trace
