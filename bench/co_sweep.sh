#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The overlap-penalty (C_o) sweep under the BVH8 kernel: `spacebvh compare` on crytek_sponza and
# crytek_sponza rotated 45/45/45 with cbvh and `spatial` at C_o = 0, 0.1, 0.3, 1, 3, 10, inf; refs,
# SAH, EPO and Mrays/s per ray kind. Answers are not checked here (--embree none: no reference rows);
# the test suite and bench/trees_shared_scenes.sh check every builder's answers. PASSES runs of each
# (default 2), one JSON file per run in bench/out/ ($BENCH_OUT); then
#   python3 bench/summarize_co.py 'bench/out/co_sweep_{scene}_[0-9]*.json'
# prints the median of the per-run ratios to cbvh. Build first: scripts/build.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
require_scenes
out=${BENCH_OUT:-bench/out}
mkdir -p "$out"
sweep=cbvh,spatial@co=0,spatial@co=0.1,spatial@co=0.3,spatial@co=1,spatial@co=3,spatial@co=10,spatial@co=inf
for pass in $(seq "${PASSES:-2}"); do
    for rotate in "" "x:45,y:45,z:45"; do
        name=crytek_sponza${rotate:+_rotated}
        ./build/spacebvh compare "$scenes/crytek_sponza/crytek_sponza.obj" ${rotate:+--rotate $rotate} --builders "$sweep" \
            --kernel bvh8 --threads 2 --runs 5 --build-runs 1 --quiet --embree none --embree-packets none \
            --json "$out/co_sweep_${name}_${pass}.json" | grep -v '^# '
    done
done
