#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Building at scale: `spacebvh build builtin:city:N` for each builder and size, one process per build
# under /usr/bin/time (its peak RSS beside the one the build reports), then one table (bench/
# scale_summary.py): build time, time per triangle, peak RSS and bytes per triangle, the memory
# estimate, the ratio to Embree MEDIUM's build time at the same size, and each builder's build-time
# exponent fitted over 10^5..10^7 triangles (log-log least squares).
#
#   bash bench/scale.sh [OUT_DIR]
#   env: SIZES="1e5 1e6 1e7"  BUILDERS="binned cbvh spatial embree-medium embree-high"
#        BIG="binned:5e7" (extra builder:size runs; empty: none)  THREADS  SPACEBVH_CLI=build/spacebvh
#        MEMORY_LIMIT=14G (each build is refused, before it starts, when its estimate exceeds this;
#        the process also gets an address-space limit of MEMORY_LIMIT + 4G as a guard)
set -euo pipefail
cd "$(dirname "$0")/.."
cli=${SPACEBVH_CLI:-build/spacebvh}
out=${1:-$(mktemp -d)}
sizes=${SIZES:-1e5 1e6 1e7}
builders=${BUILDERS:-binned cbvh spatial embree-medium embree-high}
big=${BIG-binned:5e7}
limit=${MEMORY_LIMIT:-14G}
threads=()
[ -n "${THREADS:-}" ] && threads=(--threads "$THREADS")
mkdir -p "$out"
to_bytes() { python3 -c 'import sys; t = sys.argv[1]; u = "KMGT".find(t[-1].upper()) + 1; print(int(float(t[:-1] if u else t) * 1024 ** u))' "$1"; }
guard=$(( $(to_bytes "$limit") + (4 << 30) ))

runs=()
for builder in $builders; do
  for size in $sizes; do runs+=("$builder:$size"); done
done
for run in $big; do runs+=("$run"); done

for run in "${runs[@]}"; do
  builder=${run%%:*}
  size=${run#*:}
  name="${builder}_${size}"
  echo "building builtin:city:$size with $builder" >&2
  # A refused or failed build leaves its log and no JSON; the summary lists it as such.
  prlimit --as="$guard" /usr/bin/time -f "%M" -o "$out/$name.time" \
    "$cli" build "builtin:city:$size" --builder "$builder" --no-epo --quiet "${threads[@]}" \
    --memory-limit "$limit" --json "$out/$name.json" > "$out/$name.log" 2>&1 || true
done
python3 bench/scale_summary.py "$out"
