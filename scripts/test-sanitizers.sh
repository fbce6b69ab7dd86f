#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The C++ test suite under AddressSanitizer + UndefinedBehaviorSanitizer: built into ./build-sanitized
# (clang, -O1, -fno-sanitize-recover=all: the first report fails the test; see
# scripts/lib/configure-sanitized.sh), then run with CTest. The build is also the portable
# configuration (SPACEBVH_NATIVE=OFF: the kernels choose AVX2 / AVX-512 at run time), so one run checks
# both; it shares its instrumented library with the fuzz harnesses (scripts/fuzz-build.sh).
# Left to the Release run of scripts/test.sh:
#   *SharedScene*                 the shared-scene comparisons (millions of rays on scenes of up to
#                                 0.8M triangles): several times slower under ASan than the whole rest;
#   installed_package_example     builds examples/minimal against an installed package with plain
#                                 flags, which cannot link the sanitizer runtime.
# And, unless SANITIZE_ALL=1, the heaviest tests (each 20 s to 2 min of CPU under the sanitizers on
# two cores: repeated full builds of the built-in interior and of Embree HIGH trees, every builder on
# the three largest built-in scenes, the GMP rational reference over every built-in scene, hundreds of
# thousands of packet, float64 and leaf-filter rays, the sampled reinsertion's repricing). Their code
# paths run here in the other tests, on smaller inputs; CI's time allows the rest only.
# Usage: [SANITIZE_ALL=1] bash scripts/test-sanitizers.sh [extra ctest arguments]   CI runs it from .ci/run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/install-fuzz-tools.sh
source scripts/lib/configure-sanitized.sh
cmake --build build-sanitized --target spacebvh_tests -j "$(nproc)"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
excluded='SharedScene|installed_package_example'
heavy=(ExactSpatialSweep.TreesAreValid Queries.BuiltinScenesMatchTheReference TreeFile.RoundTripEveryBuilder
       'EmbreeBuilder\.' Tracer.OrganicMeshFarFromTheOrigin LookaheadTop. Packets.TrianglesOverRays
       Packets.PartlyInactiveAndIncoherent Reinsertion.OptimizesEmbreeTrees Float64Tracer.FeatureRays
       Float64Tracer.TreeEqualsBruteForce Kernels.CallerFlushToZero WideCollapse.SahOptimalPlanBeatsLargestArea
       CityScene.EveryBuilderGivesAValidTree TerminationAwareBuild.ValidCorrectDeterministic
       TerminationReinsertion. LeafFilters.EveryCertainDecision Cli.BuildWritesConsistentJson
       Cli.SampleRaysAndTerminationRays 'BuilderOnScene\..*_(interior|interior_rotated|organic)( |$)'
       'KernelsOnScene\..*/(interior|interior_rotated|organic)( |$)' TracerWithBuilder.OrganicMeshIsWatertight
       'QuantizedKernels.AnswerAsTheArbiterOn(HugeTinyAndFar|FlatAndScattered)Scenes')
if [ -z "${SANITIZE_ALL:-}" ]; then
  excluded+="|$(IFS='|'; echo "${heavy[*]}")"
fi
(cd build-sanitized && ctest -j "$(nproc)" --output-on-failure --timeout 1800 -E "$excluded" "$@")
