#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Quantized BVH8 nodes (bvh8q) against float ones (bvh8) and Embree HIGH's rtcIntersect1/rtcOccluded1,
# side by side in one `compare` run per scene on the `spatial+opt` tree, with every layout's bytes per
# triangle (the "layout B/tri" line, `layout_bytes_per_triangle` in the JSON): the binary, bvh4 and
# bvh8 layouts, each wide one also with the moller leaf data, and Embree HIGH's BVH. Ends with the
# tables of bench/summarize_quantized.py (the median over runs with RUNS=N).
# Usage: [RUNS=2] [STEMS=...] bash bench/quantized_nodes_shared_scenes.sh > quantized.md   (build first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
export STEMS="${STEMS:-sibenik crytek_sponza living_room_3 crytek_sponza_rotated}"
out=${BENCH_OUT:-bench/out}
runs=${RUNS:-1}
bash bench/each_shared_scene.sh quantized --builders spatial+opt \
    --kernel "${KERNELS:-bvh8,bvh8q,bvh8+moller,bvh8q+moller,binary,bvh4,bvh4+moller}" --embree high --embree-packets none \
    --threads 2 --runs 5 --build-runs 1 --no-epo --quiet
if [ "$runs" -gt 1 ]; then
    python3 bench/summarize_quantized.py $(seq -f "$out/quantized_runs/%g" 1 "$runs")
else
    python3 bench/summarize_quantized.py "$out"
fi
