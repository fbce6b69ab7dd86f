#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Two builds of the CLI against each other (a kernel change against its baseline): per shared scene
# and repetition, each binary runs one `compare` of one tree under one kernel with Embree HIGH's own
# kernel as a row, the two binaries in turn (A, B, A, B, ...). The absolute speeds of two processes
# on a shared machine are not comparable, but each process's ratio to Embree, measured side by side
# in that process, is. Ends with bench/summarize_ab.py: per scene and ray kind the median over the
# repetitions of ours / Embree for A and for B, and B / A (above 1: B is faster).
# Usage: [REPS=3] [STEMS="bunny sibenik builtin:interior"] [BUILDER=spatial+opt] [KERNEL=bvh8] \
#        [RAYS=1000000] [SIDE=1024] bash bench/ab_binaries.sh A_CLI B_CLI > ab.md
#        (A_CLI, B_CLI: two spacebvh executables)
# Each scene's tree is built once by A and saved (`compare --tree`), so both binaries trace the same
# tree and no repetition spends its time building. RAYS: random rays; SIDE: the image side of the
# primary rays, from whose hits the diffuse rays start.
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
scene_of() {  # the scene arguments of a stem
    case "$1" in
        crytek_sponza_rotated) scene=("$scenes/crytek_sponza/crytek_sponza.obj" --rotate x:45,y:45,z:45) ;;
        builtin:*) scene=("$1") ;;
        *) scene=("$scenes/$1/$1.obj") ;;
    esac
}
for stem in "${stems[@]}"; do
    scene_of "$stem"
    "$1" build "${scene[@]}" --builder "${BUILDER:-spatial+opt}" --save "$out/${stem//:/_}.bvh" --quiet > /dev/null
done
side_px=${SIDE:-1024}
for rep in $(seq 1 "${REPS:-3}"); do
    for stem in "${stems[@]}"; do
        scene_of "$stem"
        for side in A B; do
            cli=$1
            [ "$side" = B ] && cli=$2
            "$cli" compare "${scene[@]}" --tree "$out/${stem//:/_}.bvh" --kernel "${KERNEL:-bvh8}" --embree high \
                --random "${RAYS:-1000000}" --width "$side_px" --height "$side_px" --threads 2 --runs 5 --no-epo \
                --quiet --json "$out/${stem//:/_}.${side}.${rep}.json" > /dev/null
        done
    done
done
python3 bench/summarize_ab.py "$out"
