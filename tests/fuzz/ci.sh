#!/usr/bin/env bash
# CI's fuzzing: builds the targets with clang and runs each for a bounded
# time over the committed corpus and the real seeds. Any crash fails.
# Usage: tests/fuzz/ci.sh [SECONDS_PER_TARGET]   (default 15)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
seconds=${1:-15}
"$root/tests/fuzz/build.sh"
targets=$(sed -n 's/^hdrstereo_fuzz_target(\([a-z0-9_]*\).*/\1/p' \
  "$root/tests/fuzz/CMakeLists.txt")
failed=()
count=0
for target in $targets; do
  count=$((count + 1))
  "$root/tests/fuzz/run.sh" "$target" "$seconds" || failed+=("$target")
done
echo "fuzz: $((count - ${#failed[@]})) of $count targets ran without a crash"
if ((${#failed[@]} > 0)); then
  echo "fuzz: crashed: ${failed[*]}" >&2
  exit 1
fi
