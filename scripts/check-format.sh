#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The C++ formatting check of the test command: every tracked C++ file as clang-format
# (.clang-format) writes it. `scripts/check-format.sh --fix` rewrites them instead.
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.inl' '*.h')
if [ "${1:-}" = "--fix" ]; then
  clang-format -i "${files[@]}"
  exit 0
fi
clang-format --dry-run --Werror "${files[@]}"
echo "check-format: ${#files[@]} C++ files formatted as .clang-format says"
