#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Tools the test command needs beyond scripts/install-deps.sh, from Debian packages: headless
# Chromium to open the generated report and check it loads with no missing image or console error,
# clang-format for the formatting check (scripts/check-format.sh), and Universal Ctags for the size
# check (scripts/check-sizes.py: where C++ functions begin and end).
# The Python packages (dask[distributed], matplotlib, tqdm, ruff) come with the package's extras.
set -euo pipefail
source "$(dirname "$0")/lib/apt-install.sh"
install_missing_packages chromium clang-format universal-ctags
