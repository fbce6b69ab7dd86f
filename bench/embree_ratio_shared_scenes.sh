#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The Embree-ratio table: per shared scene (and crytek_sponza rotated 45/45/45) and per ray kind,
# our fastest kernel on our best tree against Embree 3 HIGH's own kernel for that kind, measured side
# by side in one `compare` run per scene, 2 threads: random and diffuse rays (closest hit, occlusion)
# against rtcIntersect1/rtcOccluded1, primary rays against rtcIntersect16/rtcOccluded16 (its rays in
# 4x4 tiles, ours in 8x8 tiles). Our rows: the trees in $BUILDERS (default the reinsertion-optimised
# `cbvh+opt` and `spatial+opt`) under each kernel in $KERNELS (default the BVH8 single-ray kernel and
# 8x8 packets, each with the widest node test). Mrays/s are medians of 5 timed runs, round robin over
# the rows; every answer is checked against Embree with the exact arbiter (the wrong-answer columns).
# Ends with the ratio table of `bench/summarize_best.py --embree-kernels` (goal 1.0, misses in bold).
# RUNS=N repeats the comparison N times and gives each cell's median ratio over the runs (JSON of
# each run in bench/out/embree_ratio_runs/RUN/); STEMS="bunny living_room_3" picks scenes.
# Usage: [RUNS=3] [STEMS=...] bash bench/embree_ratio_shared_scenes.sh > ratios.md   (build first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
common=(--builders "${BUILDERS:-cbvh+opt,spatial+opt}" --kernel "${KERNELS:-bvh8,packet8}" --embree high --embree-packets high
        --tile 8 --threads 2 --runs 5 --build-runs 1 --no-epo --quiet)
runs=${RUNS:-1}
out=${BENCH_OUT:-bench/out}
read -r -a stems <<< "${STEMS:-bunny sibenik coffee_maker crytek_sponza living_room_3 crytek_sponza_rotated}"
echo "## Our fastest kernel on our best tree against Embree HIGH's own kernel per ray kind, shared scenes"
echo
bash bench/each_shared_scene.sh embree_ratio "${common[@]}"
if [ "$runs" -gt 1 ]; then
    python3 bench/summarize_best.py --embree-kernels --prefix embree_ratio $(seq -f "$out/embree_ratio_runs/%g" 1 "$runs")
else
    python3 bench/summarize_best.py --embree-kernels --prefix embree_ratio $(printf "$out/embree_ratio_%s.json " "${stems[@]/:/_}")
fi
