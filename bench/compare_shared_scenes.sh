#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The all-builders table. `spacebvh compare` with 2 threads (medians of 5 runs, builds the
# median of 3) over every shared scene and crytek_sponza rotated 45/45/45: all builders under our
# kernel (Embree's own binary trees included), Embree 3's own kernel as rows, and every answer
# checked against Embree with the exact arbiter settling disagreements ("wrong"). Then the C_o sweep
# of the `spatial` builder on crytek_sponza and its rotated variant.
# Usage: bash bench/compare_shared_scenes.sh > raw.md   (build first: scripts/build.sh). JSON per scene
# goes to bench/out/ ($BENCH_OUT).
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
cli=./build/spacebvh
out=${BENCH_OUT:-bench/out}
mkdir -p "$out"
builders=cbvh,binned,kdbvh,spatial,sbvh,esc,evh,embree-medium,embree-high
common=(--threads 2 --runs 5 --build-runs 3 --quiet --embree medium,high)

echo "## All builders, shared scenes"
echo
echo "Command: \`bash bench/compare_shared_scenes.sh\` (compare --builders $builders ${common[*]})"
echo
for scene in bunny/bunny sibenik/sibenik coffee_maker/coffee_maker crytek_sponza/crytek_sponza living_room_3/living_room_3; do
    "$cli" compare "$scenes/$scene.obj" --builders "$builders" "${common[@]}" --json "$out/$(basename $scene).json" | grep -v '^# '
done
"$cli" compare "$scenes/crytek_sponza/crytek_sponza.obj" --rotate x:45,y:45,z:45 --builders "$builders" "${common[@]}" \
    --json "$out/crytek_sponza_rotated.json" | grep -v '^# '

echo "## C_o sweep of the spatial builder"
echo
sweep=cbvh,spatial@co=0,spatial@co=0.1,spatial@co=0.3,spatial@co=1,spatial@co=3,spatial@co=10,spatial@co=inf
for rotate in "" "x:45,y:45,z:45"; do
    "$cli" compare "$scenes/crytek_sponza/crytek_sponza.obj" ${rotate:+--rotate $rotate} --builders "$sweep" \
        --threads 2 --runs 5 --build-runs 1 --quiet --embree medium | grep -v '^# '
done
