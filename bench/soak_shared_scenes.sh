#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The correctness soak: many rays of every kind (random, primary, diffuse; closest hit and occlusion)
# through every builder and every kernel on every shared scene, each answer checked against Embree HIGH
# in the same run and every disagreement settled by the exact arbiter. Prints the compare tables, then
# the wrong-answer summary of bench/summarize_soak.py (0 expected in every row of ours).
# Not a speed measurement: `compare --runs 0`, one answers-only pass per row.
# Usage: [RAYS=10000000] [BUILDERS=...] [KERNEL_GROUPS="a,b c,d"] [STEMS=...] [FRESH=1] bash bench/soak_shared_scenes.sh
# RAYS random rays per scene; primary rays from a square image large enough that at least RAYS primary
# rays and at least RAYS diffuse rays (one bounce per primary hit) are traced: a 256x256 probe of the
# scene's coverage sizes the image (a scene that fills a quarter of the view gets 4x RAYS primary rays).
# Kernels run in two groups (one compare process per builder and group: the SIMD kernels, then the
# scalar reference kernels) so the answers one process keeps stay within about 5 GiB at 10^7 rays.
# Each (builder, kernel group, scene) cell is one process whose JSON is kept under
# $BENCH_OUT/soak/BUILDER/GROUP/; a cell whose JSON exists is skipped, so an interrupted soak resumes
# where it stopped (at 10^7 rays the whole soak takes hours). FRESH=1 starts over.
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes soak
rays=${RAYS:-10000000}
read -r -a builders <<< "${BUILDERS:-cbvh binned kdbvh spatial sbvh esc evh}"
read -r -a groups <<< "${KERNEL_GROUPS:-binary,bvh4,bvh8,bvh8q,packet8,packet16,bvh4+moller,bvh8+moller,bvh8q+moller bvh4-scalar,bvh8-scalar,bvh8q-scalar,packet8-scalar,packet16-scalar}"
root=${BENCH_OUT:-bench/out}/soak
probes=$root-probe
[ -n "${FRESH:-}" ] && rm -rf "$root" "$probes"
# The image side for STEM: the share of a 256x256 probe image's primary rays that hit (and so start a
# diffuse ray), less 2 % for the probe's sampling error, decides how many primary rays give RAYS
# diffuse ones.
image_side() {
    local stem=$1
    if [ ! -f "$probes/probe_$stem.json" ]; then
        STEMS=$stem BENCH_OUT=$probes bash bench/each_shared_scene.sh probe --builders binned --kernel binary \
            --embree none --embree-packets none --random 1 --width 256 --height 256 --runs 0 --build-runs 1 \
            --no-epo --threads 2 --quiet > /dev/null
    fi
    python3 - "$probes/probe_$stem.json" "$rays" <<'PY'
import json, math, sys
counts = json.load(open(sys.argv[1]))["scenes"][0]["rays"]
rays = int(sys.argv[2])
coverage = max(0.01, counts["diffuse"] / counts["primary"] - 0.02)
print(math.isqrt(math.ceil(rays / min(1.0, coverage)) - 1) + 1)
PY
}
read -r -a stems <<< "${STEMS:-bunny sibenik coffee_maker crytek_sponza living_room_3 crytek_sponza_rotated}"
for builder in "${builders[@]}"; do
    for group in "${groups[@]}"; do
        cell="$root/$builder/${group//,/+}"
        for stem in "${stems[@]}"; do
            [ -f "$cell/soak_$stem.json" ] && continue
            side=$(image_side "$stem")
            STEMS=$stem BENCH_OUT=$cell bash bench/each_shared_scene.sh soak --builders "$builder" \
                --kernel "$group" --embree high --embree-packets none --random "$rays" --width "$side" --height "$side" \
                --runs 0 --build-runs 1 --no-epo --threads 2 --quiet
        done
    done
done
python3 bench/summarize_soak.py "$root"
