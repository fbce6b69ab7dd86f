#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Runs every fuzz harness (fuzz/) for a short fixed time over its seeds (build-sanitized/seeds/<target>)
# and its kept regression inputs (tests/data/fuzz/<target>), with ASan+UBSan; exits 1 when any
# harness reports a crash, leak, timeout or out-of-memory (the input lands in build-sanitized/artifacts/).
# Usage: bash scripts/fuzz-short.sh [SECONDS_PER_TARGET (default 15)]   CI runs it from .ci/run.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-15}"
bash scripts/fuzz-build.sh
targets=(obj ply gltf gltf_instances ray_file hit_file tree_file scene_file builder_spec)
failed=()
for target in "${targets[@]}"; do
  corpus=build-sanitized/corpus/$target artifacts=build-sanitized/artifacts/$target
  mkdir -p "$corpus" "$artifacts"
  inputs=("$corpus" "build-sanitized/seeds/$target")
  [ -d "tests/data/fuzz/$target" ] && inputs+=("tests/data/fuzz/$target")
  log=build-sanitized/fuzz-short-$target.log
  start=$SECONDS
  # -malloc_limit_mb: a size field that asks for a huge allocation is a finding, not a slow run.
  if build-sanitized/fuzz/fuzz_"$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=512 \
       -dict="fuzz/dict/$target.dict" -artifact_prefix="$artifacts/" -print_final_stats=1 "${inputs[@]}" >"$log" 2>&1; then
    status=ok
  else
    status=FAILED
    failed+=("$target")
  fi
  runs=$(grep -oE 'stat::number_of_executed_units: [0-9]+' "$log" | grep -oE '[0-9]+$' || echo "?")
  printf '%-13s %-6s %9s runs in %3d s  (%s)\n' "$target" "$status" "$runs" $((SECONDS - start)) "$log"
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz-short: ${failed[*]} failed; the inputs are in build-sanitized/artifacts/<target>/" >&2
  for target in "${failed[@]}"; do grep -m 3 -E 'ERROR|SUMMARY' "build-sanitized/fuzz-short-$target.log" >&2 || true; done
  exit 1
fi
