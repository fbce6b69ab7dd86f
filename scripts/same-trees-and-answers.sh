#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Two builds of the CLI (say main before and after a refactoring) against each other: for each
# scene and builder, `build --json` must give the same tree (nodes, references, depth, bytes, SAH;
# times excepted) and the same tree file, byte for byte, and `trace` byte-identical hit files, closest
# hit and occlusion, under the binary, the default wide and both packet kernels, on random, diffuse
# and primary rays made once by the first CLI (primary rays are the ones packets trace as packets; on
# the others they test the packet kernels' fallbacks).
# Usage: scripts/same-trees-and-answers.sh OLD_CLI NEW_CLI [SCENE ...]
# Scenes default to four of the shared scenes ($SPACEBVH_SCENES, default ../shared/scenes);
# BUILDERS (default "cbvh binned spatial sbvh kdbvh"), KERNELS (default "binary bvh8 packet8 packet16"),
# KINDS (default "random diffuse primary") and RAYS (default 100000) may be set.
set -euo pipefail
old=$(realpath "$1") new=$(realpath "$2")
shift 2
scenes_dir=${SPACEBVH_SCENES:-$(dirname "$0")/../../shared/scenes}
if [ $# -eq 0 ]; then
  set -- "$scenes_dir"/bunny/bunny.obj "$scenes_dir"/sibenik/sibenik.obj \
    "$scenes_dir"/coffee_maker/coffee_maker.obj "$scenes_dir"/crytek_sponza/crytek_sponza.obj
fi
builders=${BUILDERS:-cbvh binned spatial sbvh kdbvh}
kernels=${KERNELS:-binary bvh8 packet8 packet16}
kinds=${KINDS:-random diffuse primary}
rays=${RAYS:-100000}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The JSON fields that describe the tree, not the run.
tree_fields() {
  python3 -c 'import json, sys
d = json.load(open(sys.argv[1]))
drop = ("_ms", "saved", "time", "seconds", "memory", "threads", "version", "command", "host", "date", "rss", "per_s")
def clean(x):
    if isinstance(x, dict):
        return {k: clean(v) for k, v in sorted(x.items()) if not any(s in k for s in drop)}
    if isinstance(x, list):
        return [clean(v) for v in x]
    return x
print(json.dumps(clean(d), sort_keys=True, indent=1))' "$1"
}
differences=0 checks=0
for scene in "$@"; do
  stem=$(basename "$scene" | sed 's/\.[^.]*$//')
  for kind in $kinds; do
    "$old" rays "$scene" -q --kind "$kind" -n "$rays" --width 256 --height 256 -o "$work/$stem.$kind.rays" >/dev/null
  done
  for builder in $builders; do
    for side in old new; do
      cli=${!side}
      "$cli" build "$scene" -q --no-epo -b "$builder" --json "$work/$side.json" --save "$work/$side.tree" >/dev/null
      tree_fields "$work/$side.json" >"$work/$side.tree.txt"
    done
    checks=$((checks + 1))
    if ! diff -q "$work/old.tree.txt" "$work/new.tree.txt" >/dev/null || ! cmp -s "$work/old.tree" "$work/new.tree"; then
      echo "DIFFERENT TREE: $stem $builder"; diff "$work/old.tree.txt" "$work/new.tree.txt" | head -20
      differences=$((differences + 1))
    fi
    for kind in $kinds; do
      for kernel in $kernels; do
        for query in closest occlusion; do
          flag=(); [ "$query" = occlusion ] && flag=(--occlusion)
          for side in old new; do
            cli=${!side}
            "$cli" trace "$scene" -q --tree "$work/$side.tree" --kernel "$kernel" --rays "$work/$stem.$kind.rays" \
              --hits "$work/$side.hits" "${flag[@]}" >/dev/null
          done
          checks=$((checks + 1))
          if ! cmp -s "$work/old.hits" "$work/new.hits"; then
            echo "DIFFERENT HITS: $stem $builder $kind $kernel $query"
            differences=$((differences + 1))
          fi
        done
      done
    done
    echo "$stem $builder: compared"
  done
done
echo "same-trees-and-answers: $checks checks, $differences differences"
[ "$differences" -eq 0 ]
