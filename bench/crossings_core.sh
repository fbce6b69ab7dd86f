#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Two builds of RayQueries' crossing walks side by side (bench/crossings_core.cpp): the old and the new
# spacebvh_crossings_core binary run in turn (old, new, new, old, ...) on the same rays, ROUNDS times
# each; prints each query's median milliseconds, old / new, and whether the answers' checksums agree.
# Interleaved medians, because the machines these run on are shared.
# Usage: [RAYS=300000] [THREADS=1] [ROUNDS=6] [QUERIES=count,all,rays,contains]
#        bash bench/crossings_core.sh OLD_BINARY NEW_BINARY [SCENE...]
# (default scenes: bunny and crytek_sponza of the shared collection, bench/lib/scenes.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/lib/scenes.sh
[ $# -ge 2 ] || { sed -n 3,9p "$0" >&2; exit 2; }
old=$1 new=$2
shift 2
list=("$@")
[ ${#list[@]} -gt 0 ] || list=("$scenes/bunny/bunny.obj" "$scenes/crytek_sponza/crytek_sponza.obj")
for scene in "${list[@]}"; do
    [ -f "$scene" ] || [[ "$scene" == builtin:* ]] || { echo "skipping $scene: not there"; continue; }
    echo "$scene: ${RAYS:-300000} rays, ${THREADS:-1} threads, ${ROUNDS:-6} rounds"
    for round in $(seq "${ROUNDS:-6}"); do
        order=(old new)
        [ $((round % 2)) = 1 ] || order=(new old)
        for side in "${order[@]}"; do
            binary=$old
            [ "$side" = new ] && binary=$new
            "$binary" "$scene" "${RAYS:-300000}" "${THREADS:-1}" 3 "${QUERIES:-count,all,rays,contains}" |
                awk -v side="$side" 'NR > 1 { print side, $1, $2, $5 }'
        done
    done | python3 -c '
import collections, statistics, sys
ms, sums = collections.defaultdict(list), collections.defaultdict(set)
for line in sys.stdin:
    side, query, value, checksum = line.split()
    ms[query, side].append(float(value))
    sums[query].add(checksum)
for query in dict.fromkeys(q for q, _ in ms):
    old, new = statistics.median(ms[query, "old"]), statistics.median(ms[query, "new"])
    same = "same answers" if len(sums[query]) == 1 else "ANSWERS DIFFER"
    print(f"  {query:9s} old {old:8.1f} ms  new {new:8.1f} ms  old/new {old / new:5.3f}  {same}")
'
done
