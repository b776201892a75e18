#!/bin/bash
# Blended Intrinsic Maps quality and speed on generated creature pairs (issue 3 targets):
#  - fraction of vertices within normalized geodesic error 0.1, seeds 1..BIM_SEEDS of
#    near-isometric and non-isometric pairs (targets 0.90 / 0.75);
#  - stage breakdown of one ~12,500-vertex pair (target: 10 s total).
# Each prints PASS/FAIL against its target (bench/tool_bim_bench.cpp); exit 1 when one is missed.
# Usage: bench/bim_quality.sh [BUILD_DIR]   (environment: BIM_SEEDS=10 BIM_VERTICES=2000)
set -uo pipefail
BUILD=${1:-build}
BIN="$BUILD/tool_bim_bench"
[ -x "$BIN" ] || { echo "bim_quality: $BIN not built (cmake --build $BUILD --target tool_bim_bench)" >&2; exit 2; }
export BIM_SEEDS=${BIM_SEEDS:-10}
"$BIN" quality; q=$?
BIM_VERTICES=12500 "$BIN" timing; t=$?
[ $q -eq 0 ] && [ $t -eq 0 ]
