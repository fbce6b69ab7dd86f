#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The kernel benchmark: per shared scene (and crytek_sponza rotated
# 45/45/45), our kernels on our best tree (`spatial`) against Embree 3 in the same run, 2 threads:
# binary (the scalar reference), BVH4, BVH8 (widest node test) and 8x8 / 16x16 packets, Embree HIGH
# and MEDIUM with rtcIntersect1/rtcOccluded1 and HIGH with rtcIntersect16/rtcOccluded16 (primary rays
# in 4x4 tiles for those). Primary rays are in 8x8 tile order for every row. Mrays/s are medians of 5
# timed runs; every answer is checked against Embree with the exact arbiter ("wrong").
# Usage: bash bench/kernels_shared_scenes.sh > kernels.md   (build first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
common=(--builders spatial --kernel binary,bvh4,bvh8,packet8,packet16 --embree high,medium --embree-packets high
        --threads 2 --runs 5 --build-runs 1 --no-epo --quiet)
echo "## Kernels on the spatial tree against Embree, shared scenes"
echo
bash bench/each_shared_scene.sh kernels "${common[@]}"
