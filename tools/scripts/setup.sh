#!/usr/bin/env bash
# Sets up a Debian 12 machine for organsim and builds it (Release) in ./build.
# Installs only the Debian packages that are missing (quick when all are present)
# and builds incrementally. Run as root, or as a user with sudo, from anywhere.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build_dir=${ORGANSIM_BUILD_DIR:-$repo/build}

packages=(
  build-essential cmake ninja-build pkg-config
  libinsighttoolkit5-dev libvtk9-dev libcgal-dev libeigen3-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev libxxhash-dev libssl-dev
  libgtest-dev libbenchmark-dev
  clang-14 libclang-rt-14-dev clang-format-14
  libopencv-dev xvfb xauth
  calculix-ccx libopenigtlink-dev snakemake
  libsuitesparse-dev libmumps-seq-dev libopenblas-dev
  python3-dev pybind11-dev python3-numpy python3-pytest python3-matplotlib python3-pil dpkg-dev file time
  chromium
)

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$package" 2>/dev/null || true)
  [[ "$status" == installed ]] || missing+=("$package")
done

if ((${#missing[@]})); then
  echo "organsim setup: installing ${#missing[@]} missing Debian packages: ${missing[*]}" >&2
  if [[ $(id -u) -eq 0 ]]; then
    as_root=()
  elif command -v sudo >/dev/null; then
    as_root=(sudo)
  else
    echo "organsim setup: error: packages are missing and this is not root; run as root or install: ${missing[*]}" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  "${as_root[@]}" apt-get update -q
  "${as_root[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

if [[ ! -f "$build_dir/build.ninja" ]]; then
  cmake -S "$repo" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
fi
# Two jobs: ITK/CGAL translation units need about 1.5 GB of memory each.
cmake --build "$build_dir" -- -j "${ORGANSIM_JOBS:-2}"
echo "organsim setup: built in $build_dir" >&2
