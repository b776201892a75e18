#!/bin/bash
# Blended Intrinsic Maps quality and speed on generated creature pairs (issue 3 targets):
#  - fraction of vertices within normalized geodesic error 0.1, seeds 1..BIM_SEEDS of
#    near-isometric and non-isometric pairs (targets 0.90 / 0.75);
#  - stage breakdown of one ~12,500-vertex pair (target: 10 s total).
# Usage: bench/bim_quality.sh [BUILD_DIR]   (environment: BIM_SEEDS=10 BIM_VERTICES=2000)
# The measurements live in tests/surface/test_bim_creatures.cpp as DISABLED_ tests.
set -euo pipefail
BUILD=${1:-build}
BIN="$BUILD/test_surface"
[ -x "$BIN" ] || { echo "bim_quality: $BIN not built (cmake --build $BUILD --target test_surface)" >&2; exit 2; }
export BIM_SEEDS=${BIM_SEEDS:-10}
"$BIN" --gtest_also_run_disabled_tests --gtest_filter='BimBench.DISABLED_QualitySweep'
BIM_VERTICES=12500 "$BIN" --gtest_also_run_disabled_tests --gtest_filter='BimBench.DISABLED_Timing12k'
