#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Our best trees against Embree's best kernel: per shared scene (and crytek_sponza rotated 45/45/45),
# the reinsertion-optimised `cbvh+opt` and `spatial+opt` trees, plain SAH and with leaf blocks of
# four (`@block=4;ct=2`: the SAH prices leaves by the packs of four the kernels test, as Embree's
# does), and `spatial+opt` with leaf blocks and a reference budget of 2 (rotated Sponza's thin slanted
# triangles gain from more splitting), under the BVH8 kernel (widest node test) and 8x8 packets, against Embree 3 HIGH
# rtcIntersect1/rtcOccluded1 and rtcIntersect16/rtcOccluded16 (its primary rays in 4x4 tiles), all
# in the same run, 2 threads. Primary rays are in 8x8 tile order for every row. Mrays/s are medians
# of 5 timed runs, taken round robin over the rows; every answer is checked against Embree with the
# exact arbiter ("wrong"). Ends with the ratio summary of bench/summarize_best.py. RUNS=N repeats
# the whole comparison N times (on a shared machine Embree's rows vary between runs), keeps each
# run's JSON in bench/out/best_runs/RUN/ and summarizes the median ratio of each cell.
# Usage: [RUNS=3] bash bench/best_shared_scenes.sh > best.md   (build first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
common=(--builders "cbvh+opt,spatial+opt,cbvh+opt@block=4;ct=2,spatial+opt@block=4;ct=2,spatial+opt@budget=2;block=4;ct=2" --kernel bvh8,packet8 --embree high --embree-packets high --tile 8
        --threads 2 --runs 5 --build-runs 1 --no-epo --quiet)
runs=${RUNS:-1}
out=${BENCH_OUT:-bench/out}
echo "## Our best trees (cbvh+opt, spatial+opt) against Embree HIGH, shared scenes"
echo
bash bench/each_shared_scene.sh best "${common[@]}"
if [ "$runs" -gt 1 ]; then
    python3 bench/summarize_best.py $(seq -f "$out/best_runs/%g" 1 "$runs")
else
    python3 bench/summarize_best.py "$out"/best_{bunny,sibenik,coffee_maker,crytek_sponza,living_room_3,crytek_sponza_rotated}.json
fi
