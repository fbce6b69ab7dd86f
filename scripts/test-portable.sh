#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The portable configuration (SPACEBVH_PORTABLE=1 in scripts/build.sh: no -march=native, the kernels
# pick AVX2/AVX-512 at run time) built into ./build-portable, and its kernel and tracer tests run:
# what a wheel or distribution package built on another machine runs.
# Usage: bash scripts/test-portable.sh [extra ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
source scripts/lib/cmake-args.sh
cmake -S . -B build-portable "${cmake_args[@]}" -DCMAKE_BUILD_TYPE=Release -DSPACEBVH_NATIVE=OFF \
  -DSPACEBVH_BUILD_EXAMPLES=OFF -DSPACEBVH_INSTALL=OFF >/dev/null
cmake --build build-portable --target spacebvh_tests -j "$(nproc)"
(cd build-portable && ctest -j "$(nproc)" --output-on-failure --timeout 900 \
  -R '^(Kernels|KernelsOnScene|Packets|FusedSlabs|Tracer|TracerWithBuilder|WideCollapse|WideLayout|Queries|QueryWalks)\.' "$@")
