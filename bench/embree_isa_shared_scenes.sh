#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The single-ray kernels against Embree HIGH per instruction set: for each ISA (avx2, and avx512 where
# the CPU has it) our bvh8-ISA and packet8-ISA kernels against Embree 3 restricted to the same ISA
# (SPACEBVH_EMBREE_CONFIG="isa=ISA", passed to rtcNewDevice), on builtin:interior and the shared
# scenes: bench/embree_ratio_shared_scenes.sh's table (closest hit and occlusion for random, primary
# and diffuse rays: ours / Embree HIGH's own kernel for that kind, the median of RUNS runs, each the
# median of 5 timed runs) followed by the bytes per triangle of every layout (bench/summarize_bytes.py).
# Our kernels come from the portable build (build-portable/spacebvh, made here as bench/work_per_ray.sh
# makes it): there each ISA's kernels are compiled for that ISA alone, while a -march=native build on
# an AVX-512 machine compiles its "avx2" kernels with AVX-512 too (32 vector registers, mask
# compares), which is not what an AVX2 machine runs. CLI=PATH measures another executable.
# Usage: [ISAS="avx2 avx512"] [RUNS=5] [STEMS=...] [BUILDERS=spatial,spatial+opt,cbvh] [CLI=...] \
#        bash bench/embree_isa_shared_scenes.sh > isa.md
set -euo pipefail
cd "$(dirname "$0")/.."
cli=${CLI:-}
if [ -z "$cli" ]; then
    cmake -S . -B build-portable -DCMAKE_BUILD_TYPE=Release -DSPACEBVH_NATIVE=OFF > /dev/null
    cmake --build build-portable --target spacebvh_cli -j "$(nproc)" > /dev/null
    cli=build-portable/spacebvh
fi
default_isas=avx2
grep -qw avx512f /proc/cpuinfo && default_isas="avx2 avx512"
read -r -a isas <<< "${ISAS:-$default_isas}"
stems=${STEMS:-builtin:interior bunny sibenik coffee_maker crytek_sponza living_room_3 crytek_sponza_rotated}
root=${BENCH_OUT:-bench/out}
for isa in "${isas[@]}"; do
    echo "# $isa: bvh8-$isa and packet8-$isa against Embree HIGH with isa=$isa"
    echo
    SPACEBVH_CLI=$cli SPACEBVH_EMBREE_CONFIG="isa=$isa" RUNS=${RUNS:-5} STEMS="$stems" KERNELS="bvh8-$isa,packet8-$isa" \
        BUILDERS="${BUILDERS:-spatial,spatial+opt,cbvh}" BENCH_OUT="$root/isa_$isa" bash bench/embree_ratio_shared_scenes.sh
    echo
    python3 bench/summarize_bytes.py "$root/isa_$isa"/embree_ratio_*.json
    echo
done
