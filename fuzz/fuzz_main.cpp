// SPDX-License-Identifier: MIT
// One libFuzzer harness per reader: this file compiled with SPACEBVH_FUZZ_TARGET set to the
// target's name (fuzz/CMakeLists.txt). A clean spacebvh::Error is an expected answer to bad input;
// everything else reaches libFuzzer as a crash.
#include <cstddef>
#include <cstdint>

#include "fuzz_targets.hpp"
#include "spacebvh/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    try {
        spacebvh::fuzz::feed(SPACEBVH_FUZZ_TARGET, {data, size});
    } catch (const spacebvh::Error&) {}
    return 0;
}
