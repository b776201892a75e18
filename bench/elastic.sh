#!/usr/bin/env bash
# Elastic correspondence benchmarks (issue 4): speed on a ~5,000-vertex pair (full
# bijective run, time per outer iteration split projection/deformation) and quality
# against the BIM initialization over >= 10 seeds of generated non-isometric pairs,
# and issue 20's speed target (elastic <= 30 s at 10k vertices a side, PASS/FAIL printed).
# Usage: bench/elastic.sh [BUILD_DIR] [FILTER]   (needs test_surface built in BUILD_DIR;
#        FILTER: e.g. Speed10k to run one benchmark, default all)
# Environment: SHAPEMAP_ELASTIC_SEEDS, SHAPEMAP_ELASTIC_VERTICES, SHAPEMAP_ELASTIC_SPEED_VERTICES,
# SHAPEMAP_ELASTIC_ETA (default: the tool's auto choice of Sec. 5.2, see docs/methods.md),
# SHAPEMAP_ELASTIC_SPEED10K_VERTICES, SHAPEMAP_ELASTIC_RAMP_F_TOL.
set -euo pipefail
BUILD="${1:-build}"
FILTER="${2:-*}"
exec "$BUILD/test_surface" --gtest_also_run_disabled_tests --gtest_filter="ElasticBench.*$FILTER*"
