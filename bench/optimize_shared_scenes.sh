#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The reinsertion optimiser (--optimize, src/builders/optimize/reinsertion_optimizer.hpp) on the shared scenes and
# crytek_sponza rotated 45/45/45: binned, binned+opt, cbvh+opt, spatial and spatial+opt under the BVH8
# kernel, next to Embree HIGH's own single-ray kernel (rtcIntersect1 / rtcOccluded1), all on the same
# rays in one run per scene, 2 threads, medians of 5 runs (builds: median of 3; build ms includes the
# optimisation). Every answer is checked against Embree with the exact arbiter ("wrong").
# Usage: bash bench/optimize_shared_scenes.sh [scene stems...] > raw.md   (build first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
common=(--builders binned,binned+opt,cbvh+opt,spatial,spatial+opt --kernel bvh8 --embree high --embree-packets none
        --threads 2 --runs 5 --build-runs 3 --no-epo --quiet)
stems=("$@")
[ ${#stems[@]} -eq 0 ] && stems=(crytek_sponza crytek_sponza_rotated coffee_maker living_room_3 sibenik bunny)
STEMS="${stems[*]}" bash bench/each_shared_scene.sh optimize "${common[@]}"
