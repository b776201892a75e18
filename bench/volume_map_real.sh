#!/usr/bin/env bash
# Symmetric volume maps on real shapes (issue 19): see bench/volume_map_real.py --help.
# Reads ../shared/data when it exists (skips those pairs otherwise); a full run with both
# solvers takes about 25 minutes on 2 cores.
exec /usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/volume_map_real.py" "$@"
