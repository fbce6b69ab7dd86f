#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# README command (b): install, check the C++ formatting, build, and run every test: the C++ suite
# (GoogleTest through CTest), then the Python package installed into a fresh virtual environment
# and tested with pytest, then the self-contained wheel built, checked and tested in its own one.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/install-test-tools.sh
bash scripts/check-format.sh
python3 scripts/check-sizes.py
python3 scripts/check-design-map.py
bash scripts/build.sh
(cd build && ctest -j "$(nproc)" --output-on-failure --timeout 900)
bash scripts/test-python.sh
bash scripts/test-wheel.sh
