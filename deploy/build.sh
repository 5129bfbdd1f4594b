#!/usr/bin/env bash
# Installs dependencies, configures and builds hdrstereo.
# Usage: deploy/build.sh [BUILD_DIR] [extra cmake args...]
# HDRSTEREO_SANITIZE=1 builds with AddressSanitizer + UBSan (default build
# folder then build-asan).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/setup-deps.sh"

default_dir="$root/build"
sanitize=OFF
if [[ "${HDRSTEREO_SANITIZE:-0}" == 1 ]]; then
  default_dir="$root/build-asan"
  sanitize=ON
fi
build_dir=${1:-$default_dir}
shift || true

# ccache keeps rebuilds on 2 cores short, also across clones (paths are
# hashed relative to the repository root).
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$root}
cmake -S "$root" -B "$build_dir" -G Ninja -DHDRSTEREO_SANITIZE=$sanitize "$@"
cmake --build "$build_dir"
