#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Builds the libFuzzer harnesses (fuzz/) with clang, AddressSanitizer and UndefinedBehaviorSanitizer
# into ./build-fuzz, then writes their seed corpora into build-fuzz/seeds/<target>/ from built-in
# geometry and the heads of the scene files in ../shared/scenes (skipped when absent).
# Used by scripts/fuzz-short.sh and bench/fuzz.sh; run alone to get build-fuzz/fuzz/fuzz_<target>.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/install-fuzz-tools.sh
source scripts/lib/cmake-args.sh
# -O1: libFuzzer's usual trade of speed against sanitizer precision. fuzzer-no-link instruments every
# library for coverage; only the harnesses link libFuzzer's main.
sanitize="-fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=all -fno-omit-frame-pointer"
cmake -S . -B build-fuzz "${cmake_args[@]}" -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DCMAKE_CXX_FLAGS="$sanitize" \
  -DSPACEBVH_FUZZ=ON -DSPACEBVH_BUILD_TESTS=OFF -DSPACEBVH_BUILD_EXAMPLES=OFF -DSPACEBVH_INSTALL=OFF >/dev/null
cmake --build build-fuzz --target fuzz_all -j "$(nproc)"
rm -rf build-fuzz/seeds
scenes=../shared/scenes
[ -d "$scenes" ] || scenes=""
# The seed writer is instrumented too: leak checks belong to the harnesses' runs, not to it.
ASAN_OPTIONS=detect_leaks=0 build-fuzz/fuzz/fuzz_make_seeds build-fuzz/seeds $scenes
