#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The C++ test suite built with AddressSanitizer + UndefinedBehaviorSanitizer (GCC, RelWithDebInfo,
# -fno-sanitize-recover=all: the first report fails the test) into ./build-asan, then run with CTest.
# The build is also the portable configuration (SPACEBVH_NATIVE=OFF, no -march=native: the kernels
# choose AVX2 / AVX-512 at run time), so one build checks both in CI.
# Left to the Release run of scripts/test.sh:
#   SharedScene*                  the shared-scene comparisons (millions of rays on scenes of up to
#                                 0.3M triangles): several times slower under ASan than the whole rest;
#   installed_package_example     builds examples/minimal against the installed (here instrumented)
#                                 libraries with plain flags, which cannot link the sanitizer runtime.
# Usage: bash scripts/test-sanitizers.sh [extra ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
source scripts/lib/cmake-args.sh
sanitize="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"
cmake -S . -B build-asan "${cmake_args[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPACEBVH_NATIVE=OFF \
  -DCMAKE_CXX_FLAGS="$sanitize" -DSPACEBVH_BUILD_EXAMPLES=OFF -DSPACEBVH_INSTALL=OFF >/dev/null
cmake --build build-asan -j "$(nproc)"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
(cd build-asan && ctest -j "$(nproc)" --output-on-failure --timeout 1800 \
  -E '^(SharedScene|installed_package_example)' "$@")
