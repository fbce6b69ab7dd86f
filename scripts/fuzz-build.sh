#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Builds the libFuzzer harnesses (fuzz/) with clang, AddressSanitizer and UndefinedBehaviorSanitizer
# into ./build-sanitized (scripts/lib/configure-sanitized.sh, shared with the sanitized test suite),
# then writes their seed corpora into build-sanitized/seeds/<target>/ from built-in geometry and the
# heads of the scene files in ../shared/scenes (skipped when absent).
# Used by scripts/fuzz-short.sh and bench/fuzz.sh; run alone to get build-sanitized/fuzz/fuzz_<target>.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/install-fuzz-tools.sh
source scripts/lib/configure-sanitized.sh
cmake --build build-sanitized --target fuzz_all -j "$(nproc)"
rm -rf build-sanitized/seeds
scenes=../shared/scenes
[ -d "$scenes" ] || scenes=""
# The seed writer is instrumented too: leak checks belong to the harnesses' runs, not to it.
ASAN_OPTIONS=detect_leaks=0 build-sanitized/fuzz/fuzz_make_seeds build-sanitized/seeds $scenes
