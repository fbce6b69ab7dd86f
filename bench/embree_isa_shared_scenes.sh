#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The single-ray kernels against Embree HIGH per instruction set: for each ISA (avx2, and avx512 where
# the CPU has it) our bvh8-ISA and packet8-ISA kernels against Embree 3 restricted to the same ISA
# (SPACEBVH_EMBREE_CONFIG="isa=ISA", passed to rtcNewDevice), on builtin:interior and the shared
# scenes: bench/embree_ratio_shared_scenes.sh's table (closest hit and occlusion for random, primary
# and diffuse rays: ours / Embree HIGH's own kernel for that kind, the median of RUNS runs, each the
# median of 5 timed runs) followed by the bytes per triangle of every layout (bench/summarize_bytes.py).
# Usage: [ISAS="avx2 avx512"] [RUNS=5] [STEMS=...] [BUILDERS=spatial,spatial+opt,cbvh] \
#        bash bench/embree_isa_shared_scenes.sh > isa.md      (build first: scripts/build.sh spacebvh_cli)
set -euo pipefail
cd "$(dirname "$0")/.."
default_isas=avx2
grep -qw avx512f /proc/cpuinfo && default_isas="avx2 avx512"
read -r -a isas <<< "${ISAS:-$default_isas}"
stems=${STEMS:-builtin:interior bunny sibenik coffee_maker crytek_sponza living_room_3 crytek_sponza_rotated}
root=${BENCH_OUT:-bench/out}
for isa in "${isas[@]}"; do
    echo "# $isa: bvh8-$isa and packet8-$isa against Embree HIGH with isa=$isa"
    echo
    SPACEBVH_EMBREE_CONFIG="isa=$isa" RUNS=${RUNS:-5} STEMS="$stems" KERNELS="bvh8-$isa,packet8-$isa" \
        BUILDERS="${BUILDERS:-spatial,spatial+opt,cbvh}" BENCH_OUT="$root/isa_$isa" bash bench/embree_ratio_shared_scenes.sh
    echo
    python3 bench/summarize_bytes.py "$root/isa_$isa"/embree_ratio_*.json
    echo
done
