#!/usr/bin/env bash
# The whole test suite: installs dependencies, builds, runs ctest.
# Usage: deploy/test.sh [ctest args...]   (e.g. -R Store, -L integration)
# HDRSTEREO_SANITIZE=1 deploy/test.sh runs it under ASan + UBSan.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir="$root/build"
[[ "${HDRSTEREO_SANITIZE:-0}" == 1 ]] && build_dir="$root/build-asan"
"$root/deploy/build.sh" "$build_dir"
cd "$build_dir"
exec ctest --output-on-failure --timeout 600 -j"$(nproc)" "$@"
