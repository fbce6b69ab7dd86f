#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# What each kernel executes per ray, ours against Embree HIGH's own, on the same rays: instructions,
# simulated first-level and last-level data-cache misses, and mispredicted branches per ray, counted
# by valgrind's callgrind inside the tracing call only (bench/work_per_ray.cpp). The counts are
# deterministic, so they hold on a loaded machine where timings do not; they say whether a speed gap
# is instructions, memory or branches. valgrind runs no AVX-512, so both sides run their AVX2 code
# (the portable build picks its kernels at run time). Single thread.
# Usage: [SCENE=$SPACEBVH_SCENES/crytek_sponza/crytek_sponza.obj (bench/lib/scenes.sh)] [ROTATE=x:45,y:45,z:45|-]
#        [BUILDER=spatial+opt] [KERNELS="bvh8 bvh8+moller"] [RAYS=20000] [SIDE=160]
#        [BINARIES=DIR] bash bench/work_per_ray.sh > work.md
# BINARIES: a folder holding prebuilt portable `spacebvh` and `spacebvh_work_per_ray` (a baseline's,
# to count two builds on the same rays); without it the portable build in build-portable is made.
# SIDE: the primary image side whose hits the diffuse rays start from (about SIDE^2 diffuse rays at most).
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
scene=${SCENE:-$scenes/crytek_sponza/crytek_sponza.obj}
rotate=${ROTATE:-x:45,y:45,z:45}
builder=${BUILDER:-spatial+opt}
read -r -a kernels <<< "${KERNELS:-bvh8 bvh8+moller}"
rays=${RAYS:-20000}
side=${SIDE:-160}
[ -f "$scene" ] || [[ "$scene" == builtin:* ]] || { echo "no $scene: nothing to measure" >&2; exit 0; }
command -v valgrind > /dev/null || { echo "valgrind is not installed (apt-get install valgrind)" >&2; exit 1; }

binaries=${BINARIES:-build-portable}
if [ -z "${BINARIES:-}" ]; then
    cmake -S . -B build-portable -DCMAKE_BUILD_TYPE=Release -DSPACEBVH_NATIVE=OFF > /dev/null
    cmake --build build-portable --target spacebvh_cli spacebvh_work_per_ray -j "$(nproc)" > /dev/null
fi
cli=$binaries/spacebvh
bench=$binaries/spacebvh_work_per_ray
out=${BENCH_OUT:-bench/out}/work_per_ray
mkdir -p "$out"
transform=()
[ "$rotate" = "-" ] || transform=(--rotate "$rotate")

"$cli" rays "$scene" "${transform[@]}" --kind random -n "$rays" -o "$out/random.rays" --quiet
"$cli" rays "$scene" "${transform[@]}" --kind diffuse --width "$side" --height "$side" -o "$out/diffuse.rays" --quiet
"$cli" build "$scene" "${transform[@]}" --builder "$builder" --save "$out/tree.bvh" --quiet > /dev/null

# totals of one callgrind run, per ray: Ir D1mr+D1mw DLmr+DLmw Bcm+Bim
per_ray() {
    python3 - "$1" "$2" <<'EOF'
import sys
events, totals = None, None
for line in open(sys.argv[1]):
    if line.startswith("events:"):
        events = line.split()[1:]
    elif line.startswith("totals:") or line.startswith("summary:"):
        totals = [int(x) for x in line.split()[1:]]
v = dict(zip(events, totals))
n = float(sys.argv[2])
print("%.0f %.2f %.3f %.2f" % (v["Ir"] / n, (v["D1mr"] + v["D1mw"]) / n, (v["DLmr"] + v["DLmw"]) / n,
                               (v["Bcm"] + v["Bim"]) / n))
EOF
}

echo "# Work per ray: $scene ${rotate/-/unrotated}, our $builder tree vs Embree HIGH (valgrind, AVX2, 1 thread)"
echo
echo "| rays | query | kernel | instructions / ray | D1 misses / ray | LL misses / ray | branch mispredictions / ray | instructions / Embree's |"
echo "|---|---|---|---:|---:|---:|---:|---:|"
jobs=()
for kind in random diffuse; do for query in closest occlusion; do jobs+=("$out/$kind.rays:$query"); done; done
declare -A embree_ir lines  # by job: Embree's instructions per ray, and the table lines
for row in embree "${kernels[@]}"; do
    tree=$out/tree.bvh
    [ "$row" = embree ] && tree=embree
    file=$out/callgrind_${row//+/_}.out
    rm -f "$file" "$file".*
    # One profile per trace_rays call (per job), named $file.1, $file.2, ...
    valgrind --tool=callgrind --toggle-collect=trace_rays --dump-after=trace_rays --cache-sim=yes --branch-sim=yes \
        --callgrind-out-file="$file" "$bench" "$scene" "$rotate" "$tree" "$row" "${jobs[@]}" > "$file.txt" 2> "$file.log"
    label=$row
    [ "$row" = embree ] && label="Embree HIGH (rtcIntersect1/rtcOccluded1)"
    for j in "${!jobs[@]}"; do
        job=${jobs[$j]}
        kind=$(basename "${job%%:*}" .rays)
        query=${job##*:}
        count=$(sed -n "$((j + 1))p" "$file.txt" | cut -d' ' -f1)  # "N rays, M hit"
        read -r ir d1 ll br <<< "$(per_ray "$file.$((j + 1))" "$count")"
        [ "$row" = embree ] && embree_ir[$j]=$ir
        lines[$j]+="| $kind ($count) | $query | $label | $ir | $d1 | $ll | $br | $(python3 -c "print('%.2f' % ($ir / ${embree_ir[$j]}))") |"$'\n'
    done
done
for j in "${!jobs[@]}"; do printf '%s' "${lines[$j]}"; done
