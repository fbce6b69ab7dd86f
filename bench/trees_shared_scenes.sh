#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The space-subdivision trees under both kernels: `spatial` (default settings) against `sbvh`, `esc`, `evh`,
# `cbvh` and Embree HIGH's own binary tree (`embree-high`), each tree traced by our binary kernel and
# by our BVH8 kernel, per shared scene and crytek_sponza rotated 45/45/45, 2 threads, medians of 5
# timed runs taken round robin; every answer checked against Embree with the exact arbiter ("wrong").
# Embree 3 HIGH rtcIntersect1/rtcOccluded1 is a row too, and the reference of the "wrong" check.
# Then `python3 bench/summarize_trees.py bench/out/trees_*.json` prints the ratio table.
# Usage: bash bench/trees_shared_scenes.sh > trees.md   (build first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
echo "## Space-subdivision trees under the binary and BVH8 kernels, shared scenes"
echo
bash bench/each_shared_scene.sh trees --builders "spatial,sbvh,esc,evh,cbvh,embree-high" --kernel binary,bvh8 \
    --embree high --embree-packets none --threads 2 --runs 5 --build-runs 3 --no-epo --quiet
