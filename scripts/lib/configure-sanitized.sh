# SPDX-License-Identifier: MIT
# Configures ./build-sanitized: clang with AddressSanitizer + UndefinedBehaviorSanitizer
# (-fno-sanitize-recover=all: the first report is fatal) and libFuzzer's coverage instrumentation, at -O1
# with line tables only (libFuzzer's usual trade of speed against sanitizer precision; line tables
# are enough for symbolized reports and compile far faster than full debug information).
# One instrumented build serves both the fuzz harnesses (scripts/fuzz-build.sh) and the sanitized test
# suite (scripts/test-sanitizers.sh), so the library is compiled once for both.
# It is also the portable configuration (SPACEBVH_NATIVE=OFF: no -march=native; the kernels choose
# AVX2 / AVX-512 at run time), so the kernel tests run in it.
# Sourced after scripts/install-deps.sh and scripts/install-fuzz-tools.sh.
source "$(dirname "${BASH_SOURCE[0]}")/cmake-args.sh"
sanitize="-fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=all -fno-omit-frame-pointer"
cmake -S . -B build-sanitized "${cmake_args[@]}" -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" \
  -DCMAKE_CXX_FLAGS="$sanitize" -DSPACEBVH_NATIVE=OFF -DSPACEBVH_FUZZ=ON -DSPACEBVH_BUILD_TESTS=ON \
  -DSPACEBVH_BUILD_EXAMPLES=OFF -DSPACEBVH_INSTALL=OFF >/dev/null
