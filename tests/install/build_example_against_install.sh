#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# build_example_against_install.sh BUILD_DIR EXAMPLE_DIR CMAKE: installs the build into a fresh prefix,
# builds EXAMPLE_DIR as its own CMake project against it (find_package(spacebvh)), and runs it.
set -euo pipefail
build=$1; example=$2; cmake=${3:-cmake}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$cmake" --install "$build" --prefix "$work/prefix" >/dev/null
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
"$cmake" -S "$example" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" >/dev/null
"$cmake" --build "$work/build" >/dev/null
output=$("$work/build/minimal")
echo "$output"
# The example traces a ray at a unit square one unit away: it must hit at t = 1.
grep -q "t = 1 on triangle" <<<"$output"
