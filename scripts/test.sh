#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# README command (b): install, build, and run every test (GoogleTest through CTest).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
cd build
ctest -j "$(nproc)" --output-on-failure --timeout 900
