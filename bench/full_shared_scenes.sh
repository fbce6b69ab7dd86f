#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The Full search against the others: full, kdbvh, spatial and cbvh on the shared scenes (SAH, EPO, refs,
# build time, peak memory, Mrays/s per ray kind with the default kernels), 2 threads, one run per
# scene; JSON per scene in bench/out/ ($BENCH_OUT).
# Usage: bash bench/full_shared_scenes.sh [scene stems...] > full.md   (build first)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
out=${BENCH_OUT:-bench/out}
mkdir -p "$out"
stems=("$@")
[ ${#stems[@]} -eq 0 ] && stems=(bunny sibenik coffee_maker crytek_sponza living_room_3)
for stem in "${stems[@]}"; do
    ./build/spacebvh compare "$scenes/$stem/$stem.obj" --builders cbvh,kdbvh,spatial,full --embree high \
        --embree-packets none --threads 2 --runs 3 --build-runs 1 --quiet --json "$out/full_$stem.json" | grep -v '^# '
done
