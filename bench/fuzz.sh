#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Runs each fuzz harness (fuzz/) for at least FUZZ_RUNS executions (default 10^6) with ASan+UBSan and
# prints, per harness, the executions, crashes, leaks, timeouts and out-of-memory stops. A harness
# that stops on a finding is restarted (its corpus kept) until the executions are reached, at most
# FUZZ_MAX_STOPS times; each finding's input is in build-sanitized/artifacts/<target>/.
# Usage: bash bench/fuzz.sh [TARGET...]   (default: every target; FUZZ_RUNS, FUZZ_MAX_STOPS=20)
set -euo pipefail
cd "$(dirname "$0")/.."
goal="${FUZZ_RUNS:-1000000}"
max_stops="${FUZZ_MAX_STOPS:-20}"
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(obj ply gltf gltf_instances ray_file hit_file tree_file scene_file builder_spec)
[ -n "${FUZZ_SKIP_BUILD:-}" ] || bash scripts/fuzz-build.sh >/dev/null
printf '%-13s %10s %8s %6s %9s %5s %7s\n' target executions crashes leaks timeouts ooms seconds
for target in "${targets[@]}"; do
  corpus=build-sanitized/corpus/$target artifacts=build-sanitized/artifacts/$target
  mkdir -p "$corpus" "$artifacts"
  inputs=("$corpus" "build-sanitized/seeds/$target")
  [ -d "tests/data/fuzz/$target" ] && inputs+=("tests/data/fuzz/$target")
  executed=0 crashes=0 leaks=0 timeouts=0 ooms=0 stops=0 start=$SECONDS
  while [ "$executed" -lt "$goal" ] && [ "$stops" -lt "$max_stops" ]; do
    log=build-sanitized/bench-$target.log
    if build-sanitized/fuzz/fuzz_"$target" -runs=$((goal - executed)) -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=512 \
         -dict="fuzz/dict/$target.dict" -artifact_prefix="$artifacts/" -print_final_stats=1 "${inputs[@]}" >"$log" 2>&1; then
      :
    else
      stops=$((stops + 1))
      cp "$log" "build-sanitized/bench-$target-stop$stops.log"
      if grep -q 'ERROR: LeakSanitizer' "$log"; then leaks=$((leaks + 1))
      elif grep -q 'ERROR: libFuzzer: timeout' "$log"; then timeouts=$((timeouts + 1))
      elif grep -qE 'ERROR: libFuzzer: (out-of-memory|malloc)' "$log"; then ooms=$((ooms + 1))
      else crashes=$((crashes + 1))
      fi
    fi
    runs=$(grep -oE 'stat::number_of_executed_units: [0-9]+' "$log" | grep -oE '[0-9]+$' | tail -1 || true)
    if [ -z "$runs" ]; then  # stopped before the final stats: the last progress line
      runs=$(grep -oE '^#[0-9]+' "$log" | tail -1 | tr -d '#' || true)
    fi
    executed=$((executed + ${runs:-0}))
  done
  printf '%-13s %10d %8d %6d %9d %5d %7d\n' "$target" "$executed" "$crashes" "$leaks" "$timeouts" "$ooms" $((SECONDS - start))
done
