#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The termination-aware reinsertion (--termination-optimize) against the trees it competes with, per
# shared scene: each tree recipe is built once and saved, then the benchmark's diffuse rays (the
# manifest camera, 1024 x 1024) and random rays are traced closest-hit and any-hit with --stats under
# the BVH8 kernel. Prints a markdown table of build time, SAH, EPO and child boxes per ray; exact counts,
# independent of the machine's load (Mrays/s: bench/termination_term.sh and `compare`).
# Recipes: "label|build options", separated by ';' in $RECIPES (default below: the ablations).
# Usage: [STEMS="sibenik living_room_3"] [RECIPES=...] bash bench/termination_reinsertion.sh > treins.md
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes measure
cli=./build/spacebvh
root=${BENCH_OUT:-bench/out}/treins
read -r -a stems <<< "${STEMS:-bunny sibenik coffee_maker crytek_sponza living_room_3}"
topt="--termination-rays 4096 --no-termination-split --termination-optimize"
default_recipes="cbvh|--builder cbvh;spatial|--builder spatial;embree-high|--builder embree-high"
default_recipes+=";spatial+opt|--builder spatial --optimize"
default_recipes+=";spatial+topt4 (4096 rays)|--builder spatial $topt 4"
default_recipes+=";spatial+topt16 (4096 rays)|--builder spatial $topt 16"
default_recipes+=";spatial+topt16 prior 0|--builder spatial $topt 16 --termination-prior 0"
default_recipes+=";spatial+topt4 (16384 rays)|--builder spatial --termination-rays 16384 --no-termination-split --termination-optimize 4"
default_recipes+=";spatial+term+topt4|--builder spatial --termination-rays 4096 --termination-optimize 4"
default_recipes+=";cbvh+topt4|--builder cbvh $topt 4"
IFS=';' read -r -a recipes <<< "${RECIPES:-$default_recipes}"
common=(--threads 2 --quiet)
value() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }
echo "| scene | tree | build ms | SAH | EPO | diffuse occl. boxes | diffuse closest boxes | random occl. boxes | random closest boxes |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
for stem in "${stems[@]}"; do
    obj=$scenes/$stem/$stem.obj
    dir=$root/$stem
    mkdir -p "$dir"
    [ -s "$dir/diffuse.rays" ] || "$cli" rays "$obj" --kind diffuse -o "$dir/diffuse.rays" "${common[@]}" >&2
    [ -s "$dir/random.rays" ] || "$cli" rays "$obj" --kind random -n 200000 -o "$dir/random.rays" "${common[@]}" >&2
    for recipe in "${recipes[@]}"; do
        label=${recipe%%|*}
        read -r -a options <<< "${recipe#*|}"
        file=$(echo "$label" | tr -c 'A-Za-z0-9+\n' '_')
        [ -s "$dir/build_$file.json" ] ||
            "$cli" build "$obj" "${options[@]}" --save "$dir/$file.bvh" --json "$dir/build_$file.json" "${common[@]}" >&2
        row="| $stem | $label | $(printf %.0f "$(value "$dir/build_$file.json" build_ms)") | $(printf %.2f "$(value "$dir/build_$file.json" sah)") | $(printf %.3f "$(value "$dir/build_$file.json" epo)")"
        for set in diffuse random; do
            for mode in occlusion closest; do
                flag=(); [ $mode = occlusion ] && flag=(--occlusion)
                json=$dir/stats_${file}_${set}_$mode.json
                [ -s "$json" ] || "$cli" trace "$obj" --tree "$dir/$file.bvh" --rays "$dir/$set.rays" --hits "$dir/hits" \
                    --kernel bvh8 --stats "${flag[@]}" --json "$json" "${common[@]}" >&2
                row+=" | $(printf %.2f "$(value "$json" nodes_per_ray)")"
            done
        done
        echo "$row |"
    done
    rm -f "$dir/hits"
done
