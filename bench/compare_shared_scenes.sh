#!/usr/bin/env bash
# The benchmark of bench/RESULTS.md: `spacebvh compare` over ../shared/scenes and crytek_sponza
# rotated 45/45/45, 2 threads, medians of 5 runs, every row verified against Embree + the arbiter.
# Usage: bash bench/compare_shared_scenes.sh [extra compare options]   (build first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
scenes=../shared/scenes
if [ ! -d "$scenes" ]; then echo "no $scenes: nothing to benchmark" >&2; exit 0; fi
cli=./build/spacebvh
"$cli" compare "$scenes"/bunny/bunny.obj "$scenes"/sibenik/sibenik.obj "$scenes"/coffee_maker/coffee_maker.obj \
    "$scenes"/crytek_sponza/crytek_sponza.obj "$scenes"/living_room_3/living_room_3.obj \
    --threads 2 --json bench/compare_shared_scenes.json "$@"
"$cli" compare "$scenes"/crytek_sponza/crytek_sponza.obj --rotate x:45,y:45,z:45 \
    --threads 2 --json bench/compare_rotated_sponza.json "$@"
