#!/usr/bin/env bash
# Elastic correspondence benchmarks (issue 4): speed on a ~5,000-vertex pair (full
# bijective run, time per outer iteration split projection/deformation; target <= 30 s),
# quality against the BIM initialization over >= 10 seeds of generated non-isometric pairs,
# and issue 20's speed target (elastic <= 30 s at 10k vertices a side). Each prints
# PASS/FAIL against its target (bench/tool_elastic_bench.cpp); exit 1 when one is missed.
# Usage: bench/elastic.sh [BUILD_DIR] [all|speed5k|speed10k|quality]
#        (needs tool_elastic_bench built in BUILD_DIR: make bench, or
#         cmake --build BUILD_DIR --target tool_elastic_bench)
# Environment: SHAPEMAP_ELASTIC_SEEDS, SHAPEMAP_ELASTIC_VERTICES, SHAPEMAP_ELASTIC_SPEED_VERTICES,
# SHAPEMAP_ELASTIC_ETA (default: the tool's auto choice of Sec. 5.2, see docs/methods.md),
# SHAPEMAP_ELASTIC_SPEED10K_VERTICES, SHAPEMAP_ELASTIC_RAMP_F_TOL.
set -euo pipefail
BUILD="${1:-build}"
WHICH="${2:-all}"
exec "$BUILD/tool_elastic_bench" "$WHICH"
