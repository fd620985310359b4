#!/usr/bin/env bash
# What a user downstream does with organsim, on the build just made:
#   1. cmake --install into a temporary prefix; a separate CMake project finds
#      the package (find_package(organsim)), builds against organsim::runtime,
#      loads a model and presses it; with the direct factorizations, a program
#      that calls the BLAS itself finds the system's (organsim defines no BLAS
#      symbol in any installed library or the Python module);
#   2. the same through pkg-config (organsim-runtime.pc);
#   3. the Python module imported from the installed tree;
#   4. cpack's Debian package: its Depends, and organsim --version and
#      organsim info run from the unpacked package (dpkg-deb -x).
# Usage: install_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1
source=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix

"$build/tests/organsim-test-model" cylinder -o "$work/cylinder.organ" >/dev/null

echo "== 1. cmake --install and find_package(organsim)"
cmake --install "$build" --prefix "$prefix" >/dev/null
cmake -S "$source/tests/install/consumer" -B "$work/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$work/consumer" >/dev/null
"$work/consumer/press" "$work/cylinder.organ" | tee "$work/press.txt"
# The press point follows the tool: it moves the 5 mm pressed.
awk '{ if (!($2 > 0 && $6 > 4.99 && $6 < 5.01)) exit 1 }' "$work/press.txt"
if [[ -x $work/consumer/direct_solver_consumer ]]; then
  "$work/consumer/direct_solver_consumer"
fi
# No BLAS or LAPACK routine (Fortran names: lower case, trailing underscore,
# as dgemm_ or dpotrf_) is defined by an installed library or the Python module.
fortran_definitions() { awk '$2 ~ /^[TWVDBR]$/ && $3 ~ /^[a-z][a-z0-9_]*_$/ { print FILENAME ": " $3 }' FILENAME="$1"; }
defined=""
for library in "$prefix"/lib/*.a; do
  defined+=$(nm -g --defined-only "$library" 2>/dev/null | fortran_definitions "$library")
done
module=$(find "$prefix" -name '_organsim*.so' | head -1)
if [[ -n $module ]]; then
  defined+=$(nm -D --defined-only "$module" | fortran_definitions "$module")
fi
if [[ -n $defined ]]; then
  echo "installed files define BLAS/LAPACK-style symbols:" >&2
  echo "$defined" >&2
  exit 1
fi
echo "no BLAS or LAPACK symbol defined in $(ls "$prefix"/lib/*.a | wc -l) installed libraries${module:+ and the Python module}"

echo "== 2. pkg-config organsim-runtime"
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
pkg-config --modversion organsim-runtime
# shellcheck disable=SC2046  # the flags are words
c++ -std=c++17 -O2 "$source/tests/install/consumer/press.cpp" -o "$work/press_pc" $(pkg-config --cflags --libs organsim-runtime)
"$work/press_pc" "$work/cylinder.organ"

echo "== 3. the Python module from the installed tree"
if [[ -d $prefix/lib/python3/dist-packages/organsim ]]; then
  PYTHONPATH=$prefix/lib/python3/dist-packages /usr/bin/python3 -c "
import organsim, sys
model = organsim.load(sys.argv[1])
print('organsim', organsim.__version__, model)
" "$work/cylinder.organ"
else
  echo "(not built: no pybind11)"
fi

echo "== 4. the Debian package"
(cd "$work" && cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/package" >/dev/null)
deb=$(ls "$work"/package/organsim_*_amd64.deb)
echo "$(basename "$deb")"
depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
for needed in libvtk libinsighttoolkit libc6 libstdc++6 libeigen3-dev; do
  grep -q "$needed" <<<"$depends" || { echo "the package does not depend on $needed" >&2; exit 1; }
done
dpkg-deb -x "$deb" "$work/root"
"$work/root/usr/bin/organsim" --version
"$work/root/usr/bin/organsim" info "$work/cylinder.organ" | head -3
test -f "$work/root/usr/lib/cmake/organsim/organsimConfig.cmake"
test -f "$work/root/usr/include/organsim/multibeam/multibeam.h"
test -f "$work/root/usr/share/doc/organsim/LICENSE"
echo "install, find_package, pkg-config, Python and .deb: ok"
