#!/usr/bin/env bash
# Surface maps on real shapes (issue 20): BIM and BIM + elastic on ../shared/data's cat -> lion,
# airplane -> bird and camel-gallop pose pairs; see bench/surface_real.py --help.
# Skips when the data folder is absent; results are cached per pair in bench/out/surface_real.
exec /usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/surface_real.py" "$@"
