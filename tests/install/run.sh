#!/usr/bin/env bash
# `make install`'s contents, used as a user would (issue 21): `cmake --install` of the build
# folder into a fresh prefix; a project outside the tree finds the library with
# find_package(shapemap) and reads a surface that the installed tool generated; Debian's
# python3 imports the installed package (from the prefix's dist-packages, not the build
# folder) and reads the same counts; the tool, the Python package and the CMake package
# report one version.
# Usage: run.sh BUILD_DIR
set -euo pipefail
build=$1
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" >/dev/null
"$work/prefix/bin/shapemap" --quiet generate --shape sphere --vertices 500 -o "$work/s.obj"
cmake -S "$here/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/consumer" >/dev/null
counts=$("$work/consumer/consumer" "$work/s.obj")
pydir=$(find "$work/prefix" -type d -path "*dist-packages" | head -1)
[ -n "$pydir" ] || { echo "no dist-packages folder under the prefix" >&2; exit 1; }
read -r pyver pycounts < <(cd "$work" && PYTHONPATH=$pydir /usr/bin/python3 -c "
import shapemap, sys
assert shapemap.__file__.startswith(sys.argv[1]), shapemap.__file__
V, F = shapemap.read_surface(sys.argv[2])
print(shapemap.__version__, '%d_%d' % (len(V), len(F)))" "$pydir" "$work/s.obj")
[ "${counts// /_}" = "$pycounts" ] || { echo "consumer read '$counts', python '$pycounts'" >&2; exit 1; }
toolver=$("$work/prefix/bin/shapemap" --version | awk '{print $NF}')
cmakever=$(sed -n 's/^set(PACKAGE_VERSION "\(.*\)")$/\1/p' "$work/prefix/lib/cmake/shapemap/shapemapConfigVersion.cmake")
echo "consumer: $counts; python $pyver, tool $toolver, cmake package $cmakever"
[ "$pyver" = "$toolver" ] && [ "$toolver" = "$cmakever" ] || { echo "versions differ" >&2; exit 1; }
