#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Tools the fuzz harnesses (fuzz/) and the sanitizer build need beyond scripts/install-deps.sh:
# Debian's clang with its compiler runtime (AddressSanitizer, UndefinedBehaviorSanitizer) and libFuzzer.
# Safe to run again: apt-get skips what is already installed.
set -euo pipefail
packages=(
  clang                 # the compiler libFuzzer needs (-fsanitize=fuzzer)
  libclang-rt-14-dev    # the sanitizer runtimes for clang-14 (Debian 12's clang)
  libfuzzer-14-dev      # libFuzzer's driver
  llvm                  # llvm-symbolizer: sanitizer reports with file and line
)
source "$(dirname "$0")/lib/apt-install.sh"
install_missing_packages "${packages[@]}"
