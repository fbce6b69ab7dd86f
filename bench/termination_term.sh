#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The termination-aware split choice (--termination-rays, compare's `@trays=N`) against the same
# builders without it, per shared scene: `cbvh` and `spatial` with and without 16384 bounce rays,
# under the BVH8 kernel, 2 threads, medians of $RUNS timed runs taken round robin, every answer
# checked with the exact arbiter. JSON to $BENCH_OUT/tterm_STEM.json (default bench/out/).
# Usage: [STEMS="sibenik living_room_3"] [RUNS=3] bash bench/termination_term.sh > tterm.md
set -euo pipefail
cd "$(dirname "$0")/.."
STEMS=${STEMS:-bunny sibenik coffee_maker crytek_sponza living_room_3} \
    bash bench/each_shared_scene.sh tterm \
    --builders "cbvh,cbvh@trays=16384;tcand=8,spatial,spatial@trays=16384;tcand=8" --kernel bvh8 \
    --embree none --embree-packets none --random 200000 --threads 2 --runs "${RUNS:-3}" --build-runs 1 --no-epo --quiet
