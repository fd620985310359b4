#!/usr/bin/env bash
# Builds one fuzz target (the model-file, FEM problem or session reader) with
# clang-14 + libFuzzer + ASan/UBSan and fuzzes it for a bounded time, starting
# from its saved corpus (a folder of tests/fuzz/).
# Usage: run_fuzz.sh SOURCE_DIR BUILD_DIR SECONDS [TARGET CORPUS]
set -euo pipefail
source_dir=$1 build_dir=$2 seconds=${3:-60} target=${4:-model_reader_fuzzer} corpus=${5:-corpus}
cmake -S "$source_dir" -B "$build_dir" -G Ninja -DORGANSIM_FUZZ_ONLY=ON \
  -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$build_dir" --target "$target" >/dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$source_dir"/tests/fuzz/"$corpus"/* "$work"/
cd "$work"
# -timeout: a single input taking over 10 s is a hang; -rss_limit_mb: an input
# that makes the reader allocate > 2 GiB is a bug.
"$build_dir"/tests/fuzz/"$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
  -print_final_stats=1 "$work" 2>&1 | tail -n 15
