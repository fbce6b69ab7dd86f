#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Float64 (Tracer64, exact) vs float32 (Tracer) Mrays/s on the same tree and rays, on the built-in
# organic scene and, when the shared scenes are present (bench/lib/scenes.sh), the bunny and Sibenik. Build first
# (cmake --build build --target spacebvh_float64_bench).
set -euo pipefail
cd "$(dirname "$0")/.."
bench=build/spacebvh_float64_bench
[ -x "$bench" ] || { echo "build $bench first: cmake --build build --target spacebvh_float64_bench"; exit 1; }
source bench/lib/scenes.sh
"$bench" builtin:organic 200000 3
for scene in bunny/bunny.obj sibenik/sibenik.obj; do
  if [ -f "$scenes/$scene" ]; then "$bench" "$scenes/$scene" 200000 3
  else echo "$scenes/$scene absent: skipped"; fi
done
