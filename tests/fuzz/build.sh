#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (-fsanitize=fuzzer,address,
# undefined) in their own build folder; the normal build stays GCC.
# Usage: tests/fuzz/build.sh [BUILD_DIR]   (default: build-fuzz)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build_dir=${1:-$root/build-fuzz}
"$root/deploy/setup-deps.sh"
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$root}
cmake -S "$root" -B "$build_dir" -G Ninja \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DHDRSTEREO_FUZZ=ON -DHDRSTEREO_BUILD_TESTS=OFF -DHDRSTEREO_BUILD_BENCH=OFF
cmake --build "$build_dir" --target hdrstereo_fuzzers
