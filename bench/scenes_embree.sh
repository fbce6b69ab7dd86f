#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Instanced scenes, ours (RenderScene, each single-ray kernel) against Embree HIGH's two-level scene on
# the same rays, in one process per scene: the built-in organic mesh and, when the shared scenes are
# present (bench/lib/scenes.sh), the bunny, Sibenik, the coffee maker and Crytek Sponza, each placed
# INSTANCES times (default 300) by rotations, mirrors and non-uniform scales, on random, primary and
# diffuse rays; the flattened scene where it fits (under 4M triangles: the bunny again at
# FLAT_INSTANCES placements, default 50, so the two-level against flattened rows print); top-level
# builds of 10^3 .. MAX_TOP instances (default 10^6) against Embree's; then spacebvh_refit_bench: the living room's refit (786k
# triangles) against its builds and Embree's refit, and the bunny's SAH growth under motion.
# Build first (bash scripts/build.sh spacebvh_scenes_bench). Speeds are measured here, never asserted.
set -euo pipefail
cd "$(dirname "$0")/.."
bench=build/spacebvh_scenes_bench
refit=build/spacebvh_refit_bench
[ -x "$bench" ] && [ -x "$refit" ] ||
  { echo "build first: bash scripts/build.sh spacebvh_scenes_bench spacebvh_refit_bench"; exit 1; }
instances=${INSTANCES:-300}
rays=${RAYS:-200000}
source bench/lib/scenes.sh
max_top=${MAX_TOP:-1000000}
"$bench" builtin:organic "$instances" "$rays" 5 "$max_top"
for scene in bunny/bunny.obj sibenik/sibenik.obj coffee_maker/coffee_maker.obj crytek_sponza/crytek_sponza.obj; do
  if [ -f "$scenes/$scene" ]; then "$bench" "$scenes/$scene" "$instances" "$rays" 5
  else echo "$scenes/$scene absent: skipped"; fi
done
if [ -f "$scenes/bunny/bunny.obj" ]; then "$bench" "$scenes/bunny/bunny.obj" "${FLAT_INSTANCES:-50}" "$rays" 5
else echo "$scenes/bunny/bunny.obj absent: no flattened comparison"; fi
if [ -f "$scenes/living_room_3/living_room_3.obj" ]; then "$refit" "$scenes/living_room_3/living_room_3.obj" 0 3
else echo "$scenes/living_room_3/living_room_3.obj absent: skipped"; fi
"$refit" "${SPACEBVH_REFIT_SCENE:-builtin:organic}" 100000 5
