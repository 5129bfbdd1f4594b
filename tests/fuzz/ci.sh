#!/usr/bin/env bash
# CI's fuzzing: builds the targets with clang and runs each for a bounded
# time over the committed corpus and the real seeds. Any crash fails.
# Usage: tests/fuzz/ci.sh [SECONDS_PER_TARGET]   (default 15)
# The random seed is the commit's (HDRSTEREO_FUZZ_SEED overrides it): each
# commit explores inputs of its own, and a failure reruns the same way.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
seconds=${1:-15}
"$root/tests/fuzz/build.sh"
targets=$(sed -n 's/^hdrstereo_fuzz_target(\([a-z0-9_]*\).*/\1/p' \
  "$root/tests/fuzz/CMakeLists.txt")
seed=${HDRSTEREO_FUZZ_SEED:-$((16#$(git -C "$root" rev-parse --short=7 HEAD 2>/dev/null || echo 1)))}
echo "fuzz: seed $seed"
failed=()
count=0
for target in $targets; do
  count=$((count + 1))
  "$root/tests/fuzz/run.sh" "$target" "$seconds" -seed="$seed" ||
    failed+=("$target")
done
echo "fuzz: $((count - ${#failed[@]})) of $count targets ran without a crash"
if ((${#failed[@]} > 0)); then
  echo "fuzz: crashed: ${failed[*]}" >&2
  exit 1
fi
