#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Tools the report tests need beyond scripts/install-deps.sh: headless Chromium (Debian's `chromium`)
# to open the generated report and check it loads with no missing image or console error.
# The Python packages (dask[distributed], matplotlib, tqdm) come with the package's extras.
set -euo pipefail
if command -v chromium >/dev/null; then
  exit 0
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq chromium >/dev/null
