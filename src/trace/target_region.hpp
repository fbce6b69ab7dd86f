// SPDX-License-Identifier: MIT
// A region of a file compiled for wider instructions than the build's baseline, so that one portable
// build carries each instruction set's copy of a kernel and picks one at run time (the CPU's report):
//     SPACEBVH_TARGET_BEGIN("avx2,fma")  ...functions...  SPACEBVH_TARGET_END()
// GCC takes its target pragma; clang ignores that pragma, and its attribute pragma does the same.
#pragma once

#define SPACEBVH_PRAGMA(...) _Pragma(#__VA_ARGS__)
#if defined(__clang__)
#define SPACEBVH_TARGET_BEGIN(isa) \
    SPACEBVH_PRAGMA(clang attribute push(__attribute__((target(isa))), apply_to = function))
#define SPACEBVH_TARGET_END() SPACEBVH_PRAGMA(clang attribute pop)
#else
#define SPACEBVH_TARGET_BEGIN(isa) SPACEBVH_PRAGMA(GCC push_options) SPACEBVH_PRAGMA(GCC target(isa))
#define SPACEBVH_TARGET_END() SPACEBVH_PRAGMA(GCC pop_options)
#endif
