#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Installs what spacebvh needs to build and test on Debian 12, from Debian packages only.
# Safe to run again: apt-get skips what is already installed.
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config
  ccache                # a second build of the same sources (the Python package's) comes from the cache
  libtbb-dev            # oneTBB: parallel build and tracing
  libembree-dev         # Embree 3: the yardstick in `spacebvh compare` and the test oracle
  libtinygltf-dev       # glTF 2.0 scenes (.gltf/.glb)
  libstb-dev            # PNG output (stb_image_write)
  libcli11-dev          # command line
  nlohmann-json3-dev    # --json output
  libgtest-dev          # tests
  libgmp-dev            # exact rational reference in the query tests
  python3-dev python3-venv  # the Python package (pyproject.toml): headers, and venv for the tests
)
source "$(dirname "$0")/lib/apt-install.sh"
install_missing_packages "${packages[@]}"
