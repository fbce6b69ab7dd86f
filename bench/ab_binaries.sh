#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Two builds of the CLI against each other (a kernel change against its baseline): per shared scene
# and repetition, each binary runs one `compare` of one tree under one kernel with Embree HIGH's own
# kernel as a row, the two binaries in turn (A, B, A, B, ...). The absolute speeds of two processes
# on a shared machine are not comparable, but each process's ratio to Embree, measured side by side
# in that process, is. Ends with bench/summarize_ab.py: per scene and ray kind the median over the
# repetitions of ours / Embree for A and for B, and B / A (above 1: B is faster).
# Usage: [REPS=3] [STEMS="bunny sibenik"] [BUILDER=spatial+opt] [KERNEL=bvh8] \
#        bash bench/ab_binaries.sh A_CLI B_CLI > ab.md      (A_CLI, B_CLI: two spacebvh executables)
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -eq 2 ] || { echo "usage: bash bench/ab_binaries.sh A_CLI B_CLI" >&2; exit 2; }
for cli in "$1" "$2"; do [ -x "$cli" ] || { echo "not an executable: $cli" >&2; exit 2; }; done
source bench/lib/scenes.sh
require_scenes
out=${BENCH_OUT:-bench/out}/ab
rm -rf "$out"
mkdir -p "$out"
read -r -a stems <<< "${STEMS:-bunny sibenik crytek_sponza crytek_sponza_rotated}"
echo "A: $1; B: $2; ${BUILDER:-spatial+opt} under ${KERNEL:-bvh8}, ${REPS:-3} repetitions, 2 threads, medians of 5 runs each"
echo
for rep in $(seq 1 "${REPS:-3}"); do
    for stem in "${stems[@]}"; do
        if [ "$stem" = crytek_sponza_rotated ]; then
            scene=("$scenes/crytek_sponza/crytek_sponza.obj" --rotate x:45,y:45,z:45)
        else
            scene=("$scenes/$stem/$stem.obj")
        fi
        for side in A B; do
            cli=$1
            [ "$side" = B ] && cli=$2
            "$cli" compare "${scene[@]}" --builders "${BUILDER:-spatial+opt}" --kernel "${KERNEL:-bvh8}" --embree high \
                --threads 2 --runs 5 --build-runs 1 --no-epo --quiet --json "$out/${stem}.${side}.${rep}.json" > /dev/null
        done
    done
done
python3 bench/summarize_ab.py "$out"
