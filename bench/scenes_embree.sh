#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Instanced scenes, ours (RenderScene, each single-ray kernel) against Embree HIGH's two-level scene on
# the same rays, in one process per scene: the built-in organic mesh and, when the shared scenes are
# present (bench/lib/scenes.sh), the bunny and Sibenik, each placed INSTANCES times (default 300) by
# rotations, mirrors and non-uniform scales; the flattened scene where it fits; refit against build.
# Build first (bash scripts/build.sh spacebvh_scenes_bench). Speeds are measured here, never asserted.
set -euo pipefail
cd "$(dirname "$0")/.."
bench=build/spacebvh_scenes_bench
[ -x "$bench" ] || { echo "build $bench first: bash scripts/build.sh spacebvh_scenes_bench"; exit 1; }
instances=${INSTANCES:-300}
rays=${RAYS:-200000}
source bench/lib/scenes.sh
"$bench" builtin:organic "$instances" "$rays" 5
for scene in bunny/bunny.obj sibenik/sibenik.obj; do
  if [ -f "$scenes/$scene" ]; then "$bench" "$scenes/$scene" "$instances" "$rays" 5
  else echo "$scenes/$scene absent: skipped"; fi
done
