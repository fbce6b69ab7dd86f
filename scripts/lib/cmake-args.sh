# SPDX-License-Identifier: MIT
# Sets cmake_args (Ninja when present, ccache as the compiler launcher when present) and CCACHE_BASEDIR
# (paths relative to the checkout in ccache's keys, so build folders and checkouts share objects).
# Sourced by the scripts that configure a build folder of their own.
cmake_args=()
command -v ninja >/dev/null && cmake_args+=(-G Ninja)
command -v ccache >/dev/null && cmake_args+=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
