#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Runs `spacebvh compare ARGS...` once per shared scene (one process per scene, so every row of a
# scene's table is measured side by side), writing $BENCH_OUT/PREFIX_STEM.json (default bench/out/)
# and printing the tables.
# Stems: bunny sibenik coffee_maker crytek_sponza living_room_3 crytek_sponza_rotated (crytek_sponza
# rotated 45/45/45), or those in $STEMS, which may name built-in scenes too (builtin:interior, its
# JSON named builtin_interior). RUNS=N repeats the whole loop N times (on a shared machine
# Embree's rows vary between runs) and keeps each run's JSON in $BENCH_OUT/PREFIX_runs/RUN/. Used by
# bench/PREFIX_shared_scenes.sh, whose command line it prints first. SPACEBVH_CLI: the executable
# (default ./build/spacebvh).
# Usage: [RUNS=N] bash bench/each_shared_scene.sh PREFIX COMPARE_ARGS...   (from the repository root)
set -euo pipefail
prefix=$1
shift
source "$(dirname "$0")/lib/scenes.sh"
require_scenes
cli=${SPACEBVH_CLI:-./build/spacebvh}
out=${BENCH_OUT:-bench/out}
runs=${RUNS:-1}
mkdir -p "$out"
echo "Command: \`bash bench/${prefix}_shared_scenes.sh\` (compare $*)"
echo
read -r -a stems <<< "${STEMS:-bunny sibenik coffee_maker crytek_sponza living_room_3 crytek_sponza_rotated}"
for run in $(seq 1 "$runs"); do
    [ "$runs" -gt 1 ] && echo "### Run $run of $runs" && echo
    for stem in "${stems[@]}"; do
        if [ "$stem" = crytek_sponza_rotated ]; then
            scene=("$scenes/crytek_sponza/crytek_sponza.obj" --rotate x:45,y:45,z:45)
        elif [[ "$stem" == builtin:* ]]; then
            scene=("$stem")
        else
            scene=("$scenes/$stem/$stem.obj")
        fi
        name=${stem/:/_}  # builtin:interior -> builtin_interior
        "$cli" compare "${scene[@]}" "$@" --json "$out/${prefix}_$name.json" | grep -v '^# '
        if [ "$runs" -gt 1 ]; then
            mkdir -p "$out/${prefix}_runs/$run"
            cp "$out/${prefix}_$name.json" "$out/${prefix}_runs/$run/"
        fi
    done
done
