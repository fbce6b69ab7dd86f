#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Loading a saved tree against building it (docs/tree-format.md). Builds the `spatial` tree of
# crytek_sponza (the shared scenes, bench/lib/scenes.sh) BUILDS times and saves it, loads it LOADS times (through
# `spacebvh trace --tree`, which reports the load: read, checksum, geometry hash and tree checks),
# and prints the median load time / median build time (goal: <= 0.1). Then checks that the loaded
# tree's hit files (closest hits and occlusion, 1M random rays) equal the built tree's, byte for byte.
#
#   bash bench/tree_file_load.sh [SCENE] [BUILDER]      (env: SPACEBVH_CLI, BUILDS=3, LOADS=7, THREADS)
set -euo pipefail
cd "$(dirname "$0")/.."
cli=${SPACEBVH_CLI:-build/spacebvh}
source bench/lib/scenes.sh
scene=${1:-$scenes/crytek_sponza/crytek_sponza.obj}
builder=${2:-spatial}
builds=${BUILDS:-3}
loads=${LOADS:-7}
threads=()
[ -n "${THREADS:-}" ] && threads=(--threads "$THREADS")
if [ ! -f "$scene" ]; then
  echo "no scene at $scene (set SPACEBVH_SCENES): nothing to measure"
  exit 0
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
json_field() { python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])' "$1" "$2"; }
median() { python3 -c 'import statistics, sys; print(statistics.median(float(x) for x in sys.argv[1:]))' "$@"; }

build_ms=()
for _ in $(seq "$builds"); do
  "$cli" build "$scene" --builder "$builder" --no-epo --quiet "${threads[@]}" --save "$tmp/tree.sbvh" \
    --json "$tmp/build.json" >/dev/null
  build_ms+=("$(json_field "$tmp/build.json" build_ms)")
done
"$cli" rays "$scene" --kind random --count 1000000 -o "$tmp/rays.bin" >/dev/null
load_ms=()
for _ in $(seq "$loads"); do
  "$cli" trace "$scene" --tree "$tmp/tree.sbvh" --rays "$tmp/rays.bin" --hits "$tmp/loaded.bin" "${threads[@]}" \
    --json "$tmp/trace.json" >/dev/null
  load_ms+=("$(json_field "$tmp/trace.json" tree_load_ms)")
done
"$cli" trace "$scene" --tree "$tmp/tree.sbvh" --rays "$tmp/rays.bin" --hits "$tmp/loaded_occ.bin" --occlusion \
  "${threads[@]}" >/dev/null
"$cli" trace "$scene" --builder "$builder" --rays "$tmp/rays.bin" --hits "$tmp/built.bin" "${threads[@]}" >/dev/null
"$cli" trace "$scene" --builder "$builder" --rays "$tmp/rays.bin" --hits "$tmp/built_occ.bin" --occlusion \
  "${threads[@]}" >/dev/null

build=$(median "${build_ms[@]}")
load=$(median "${load_ms[@]}")
echo "scene          $scene"
echo "builder        $builder, threads ${THREADS:-all} ($(nproc) cores)"
echo "tree file      $(stat -c %s "$tmp/tree.sbvh") bytes"
echo "build ms       ${build_ms[*]} (median $build)"
echo "load ms        ${load_ms[*]} (median $load)"
python3 -c 'import sys; print("load / build   %.4f (goal <= 0.1)" % (float(sys.argv[1]) / float(sys.argv[2])))' "$load" "$build"
if cmp -s "$tmp/built.bin" "$tmp/loaded.bin" && cmp -s "$tmp/built_occ.bin" "$tmp/loaded_occ.bin"; then
  echo "hit files      identical (closest and occlusion, 1000000 random rays)"
else
  echo "hit files      DIFFER"
  exit 1
fi
