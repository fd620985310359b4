#!/usr/bin/env bash
# README command (b): set up, build, and run the whole test suite (including a
# bounded libFuzzer run of the model-file reader).
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
bash "$repo/tools/scripts/setup.sh"
cd "${ORGANSIM_BUILD_DIR:-$repo/build}"
ctest --output-on-failure -j 2
