#!/usr/bin/env bash
# The kernel benchmark of bench/RESULTS.md (issue #5): per shared scene (and crytek_sponza rotated
# 45/45/45), our kernels on our best tree (`spatial`) against Embree 3 in the same run, 2 threads:
# binary (the scalar reference), BVH4, BVH8 (widest node test) and 8x8 / 16x16 packets, Embree HIGH
# and MEDIUM with rtcIntersect1/rtcOccluded1 and HIGH with rtcIntersect16/rtcOccluded16 (primary rays
# in 4x4 tiles for those). Primary rays are in 8x8 tile order for every row. Mrays/s are medians of 5
# timed runs; every answer is checked against Embree with the exact arbiter ("wrong").
# Usage: bash bench/kernels_shared_scenes.sh > kernels.md   (build first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
scenes=../shared/scenes
if [ ! -d "$scenes" ]; then echo "no $scenes: nothing to benchmark" >&2; exit 0; fi
cli=./build/spacebvh
common=(--builders spatial --kernel binary,bvh4,bvh8,packet8,packet16 --embree high,medium --embree-packets high
        --threads 2 --runs 5 --build-runs 1 --no-epo --quiet)
echo "## Kernels on the spatial tree against Embree, shared scenes"
echo
echo "Command: \`bash bench/kernels_shared_scenes.sh\` (compare ${common[*]})"
echo
for scene in bunny/bunny sibenik/sibenik coffee_maker/coffee_maker crytek_sponza/crytek_sponza living_room_3/living_room_3; do
    "$cli" compare "$scenes/$scene.obj" "${common[@]}" --json "bench/kernels_$(basename $scene).json" | grep -v '^# '
done
"$cli" compare "$scenes/crytek_sponza/crytek_sponza.obj" --rotate x:45,y:45,z:45 "${common[@]}" \
    --json bench/kernels_crytek_sponza_rotated.json | grep -v '^# '
