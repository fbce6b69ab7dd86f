#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Go/no-go for a termination-aware cost: does a cheap, view-independent ray sample rank trees the way
# the benchmark's diffuse rays do? Per shared scene it saves each tree once (build --save), writes
# the benchmark's diffuse rays (the manifest camera, 1024 x 1024) and two samples of $SAMPLES rays
# (`rays --kind bounce|area`, docs/cli.md), then traces every ray set with --stats under the BVH8
# and binary kernels, closest hit and occlusion, and times the diffuse rays without --stats
# ($TIMED_RUNS runs each, the fastest kept). bench/summarize_termination.py prints the rank
# correlations (Spearman, Kendall) of each predictor (SAH, EPO, the samples' boxes per ray) with
# the diffuse rays' boxes per ray and Mrays/s.
# Everything lands in $BENCH_OUT/termination/STEM/ (default bench/out/); files already there are
# reused, so an interrupted run resumes.
# Usage: [STEMS="bunny sibenik"] [TREES="cbvh spatial"] bash bench/termination_gonogo.sh > gonogo.md
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes measure
cli=./build/spacebvh
root=${BENCH_OUT:-bench/out}/termination
samples=${SAMPLES:-16384}
runs=${TIMED_RUNS:-3}
read -r -a stems <<< "${STEMS:-bunny sibenik coffee_maker crytek_sponza living_room_3}"
read -r -a trees <<< "${TREES:-cbvh spatial spatial+opt binned+opt embree-high embree-medium}"
common=(--threads 2 --quiet)
for stem in "${stems[@]}"; do
    obj=$scenes/$stem/$stem.obj
    dir=$root/$stem
    mkdir -p "$dir"
    [ -s "$dir/diffuse.rays" ] || "$cli" rays "$obj" --kind diffuse -o "$dir/diffuse.rays" "${common[@]}" >&2
    for kind in bounce area; do
        [ -s "$dir/$kind.rays" ] || "$cli" rays "$obj" --kind $kind -n "$samples" -o "$dir/$kind.rays" "${common[@]}" >&2
    done
    for tree in "${trees[@]}"; do
        [ -s "$dir/build_$tree.json" ] ||
            "$cli" build "$obj" --builder "$tree" --save "$dir/$tree.bvh" --json "$dir/build_$tree.json" "${common[@]}" >&2
        for kernel in bvh8 binary; do
            for set in diffuse bounce area; do
                for mode in closest occlusion; do
                    flag=(); [ $mode = occlusion ] && flag=(--occlusion)
                    json=$dir/stats_${tree}_${kernel}_${set}_$mode.json
                    [ -s "$json" ] || "$cli" trace "$obj" --tree "$dir/$tree.bvh" --rays "$dir/$set.rays" --hits "$dir/hits" \
                        --kernel $kernel --stats "${flag[@]}" --json "$json" "${common[@]}" >&2
                    [ $set = diffuse ] || continue
                    for run in $(seq 1 "$runs"); do
                        json=$dir/time_${tree}_${kernel}_${set}_${mode}_$run.json
                        [ -s "$json" ] || "$cli" trace "$obj" --tree "$dir/$tree.bvh" --rays "$dir/$set.rays" --hits "$dir/hits" \
                            --kernel $kernel "${flag[@]}" --json "$json" "${common[@]}" >&2
                    done
                done
            done
        done
    done
    rm -f "$dir/hits"
done
python3 bench/summarize_termination.py "$root"
