#!/usr/bin/env bash
# Symmetric volume map benchmarks (issue 5): generated creature pairs tetrahedralized to
# ~30k tets, >= 5 seeds, landmark (default) or automatic initialization; prints Table 3
# metrics per direction, stage breakdown, time and peak memory, then PASS/FAIL against the
# issue's targets (bench/tool_volume_map_bench.cpp); exit 1 when one is missed.
# Usage: bench/volume_map.sh [BUILD_DIR]   (needs tool_volume_map_bench built in BUILD_DIR)
# Environment: SHAPEMAP_VOLUME_SEEDS (5), SHAPEMAP_VOLUME_TETS (30000),
#   SHAPEMAP_VOLUME_LANDMARKS (20), SHAPEMAP_VOLUME_INIT (landmarks|auto), SHAPEMAP_VOLUME_SWAP (0|1).
set -euo pipefail
BUILD="${1:-build}"
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
exec "$BUILD/tool_volume_map_bench"
