#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# build.sh [TARGET...]: configures spacebvh (Release, -O3 -march=native) in ./build and builds the
# TARGETs, or everything (the tests, examples and bench programs too) when none is named.
# SPACEBVH_PORTABLE=1 builds without -march=native.
set -euo pipefail
cd "$(dirname "$0")/.."
native=ON
[ "${SPACEBVH_PORTABLE:-0}" = "1" ] && native=OFF
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
# ccache, when present, shares compiled objects between checkouts and rebuilds.
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# Paths relative to the checkout in ccache's keys, so the Python package's build (build-pip/, beside
# build/) and other checkouts find these objects.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
# The Python module is built for the python3 on PATH (the one scripts/install-deps.sh prepared);
# with SPACEBVH_BUILD_PYTHON off (the default) CMake is told not to warn that the setting is unused.
cmake -S . -B build --no-warn-unused-cli "${generator[@]}" "${launcher[@]}" -DCMAKE_BUILD_TYPE=Release -DSPACEBVH_NATIVE=$native \
  -DPython3_EXECUTABLE="$(command -v python3)" >/dev/null
# The configuration is the same whatever is built, so that a build of one target (scripts/run.sh)
# and a later full build (scripts/test.sh) share ./build and every object compiled in it.
targets=()
[ $# -gt 0 ] && targets=(--target "$@")
cmake --build build -j "$(nproc)" "${targets[@]}"
