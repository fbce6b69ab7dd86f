#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# README command (a): install, build, and run the main job (`spacebvh compare`) on the built-in
# default scene. Extra arguments go to `spacebvh compare`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
if [ $# -eq 0 ]; then set -- builtin:interior; fi
./build/spacebvh compare "$@"
