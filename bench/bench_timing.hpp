// SPDX-License-Identifier: MIT
// Wall-clock timing shared by the C++ benchmarks: milliseconds since a start, and the median of runs.
#pragma once

#include <algorithm>
#include <chrono>
#include <functional>
#include <utility>
#include <vector>

namespace spacebvh::bench {

inline double ms_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// The median of timings taken elsewhere (a library's own clock); `ms` must not be empty.
inline double median_of(std::vector<double> ms) {
    std::sort(ms.begin(), ms.end());
    return ms[ms.size() / 2];
}

// The median over `runs` timed calls of `work` (the machines are shared: medians, not means).
inline double median_ms(int runs, const std::function<void()>& work) {
    std::vector<double> ms;
    for (int r = 0; r < runs; ++r) {
        const auto start = std::chrono::steady_clock::now();
        work();
        ms.push_back(ms_since(start));
    }
    return median_of(std::move(ms));
}

}  // namespace spacebvh::bench
