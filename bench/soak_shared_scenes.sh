#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The correctness soak: many rays of every kind (random, primary, diffuse; closest hit and occlusion)
# through every builder and every kernel on every shared scene, each answer checked against Embree HIGH
# in the same run and every disagreement settled by the exact arbiter. Prints the compare tables, then
# the wrong-answer summary of bench/summarize_soak.py (0 expected in every row of ours).
# Not a speed measurement: `compare --runs 0`, one answers-only pass per row.
# Usage: [RAYS=10000000] [BUILDERS=...] [KERNEL_GROUPS="a,b c,d"] [STEMS=...] [FRESH=1] bash bench/soak_shared_scenes.sh
# RAYS random rays per scene, and about as many primary rays (a square image); diffuse rays follow the
# primary hits. Kernels run in two groups (one compare process per builder and group: the SIMD kernels,
# then the scalar reference kernels) so the answers one process keeps stay within about 5 GiB at 10^7
# rays. Each (builder, kernel group, scene) cell is one process
# whose JSON is kept under $BENCH_OUT/soak/BUILDER/GROUP/; a cell whose JSON exists is skipped, so an
# interrupted soak resumes where it stopped (at 10^7 rays the whole soak takes hours). FRESH=1 starts over.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -d ../shared/scenes ]; then echo "no ../shared/scenes: nothing to soak" >&2; exit 0; fi
rays=${RAYS:-10000000}
side=$(python3 -c "import math; print(max(1, math.isqrt($rays)))")
read -r -a builders <<< "${BUILDERS:-cbvh binned kdbvh spatial sbvh esc evh}"
read -r -a groups <<< "${KERNEL_GROUPS:-binary,bvh4,bvh8,bvh8q,packet8,packet16,bvh4+moller,bvh8+moller,bvh8q+moller bvh4-scalar,bvh8-scalar,bvh8q-scalar,packet8-scalar,packet16-scalar}"
root=${BENCH_OUT:-bench/out}/soak
[ -n "${FRESH:-}" ] && rm -rf "$root"
read -r -a stems <<< "${STEMS:-bunny sibenik coffee_maker crytek_sponza living_room_3 crytek_sponza_rotated}"
for builder in "${builders[@]}"; do
    for group in "${groups[@]}"; do
        cell="$root/$builder/${group//,/+}"
        for stem in "${stems[@]}"; do
            [ -f "$cell/soak_$stem.json" ] && continue
            STEMS=$stem BENCH_OUT=$cell bash bench/each_shared_scene.sh soak --builders "$builder" \
                --kernel "$group" --embree high --embree-packets none --random "$rays" --width "$side" --height "$side" \
                --runs 0 --build-runs 1 --no-epo --threads 2 --quiet
        done
    done
done
python3 bench/summarize_soak.py "$root"
