#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# README command (a): install, build, and run the main job (`spacebvh compare`) on the built-in
# default scene. Extra arguments go to `spacebvh compare`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
# Only the command-line tool: the tests, examples and bench programs are scripts/test.sh's to build.
bash scripts/build.sh spacebvh_cli
if [ $# -eq 0 ]; then set -- builtin:interior; fi
./build/spacebvh compare "$@"
