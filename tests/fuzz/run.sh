#!/usr/bin/env bash
# Runs one fuzz target for a bounded time over the committed corpus (and the
# real files in ../shared/data that suit it), then prints its executions and
# coverage. A crash, a hang (-timeout) or an allocation over the malloc limit
# fails the run; the input that did it is printed and kept.
#
# Usage: tests/fuzz/run.sh TARGET SECONDS [libFuzzer flags...]
# Environment:
#   HDRSTEREO_FUZZ_BUILD  the clang build folder (default: build-fuzz)
#   HDRSTEREO_FUZZ_WORK   where the grown corpus and crashes go (default: a
#                         new folder under /tmp, kept and named at the end)
#   HDRSTEREO_FUZZ_MERGE=1  run from the committed corpus alone (no real
#                         seeds), then replace the committed corpus with the
#                         minimised merge of it and what this run found: other
#                         labs' files, and inputs grown from them, never enter
#                         the repository
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
fuzz_dir=$root/tests/fuzz
target=${1:?usage: run.sh TARGET SECONDS [libFuzzer flags...]}
seconds=${2:?usage: run.sh TARGET SECONDS [libFuzzer flags...]}
shift 2
build=${HDRSTEREO_FUZZ_BUILD:-$root/build-fuzz}
binary=$build/tests/fuzz/$target
[[ -x $binary ]] || { echo "run.sh: no $binary (build it: tests/fuzz/build.sh)" >&2; exit 2; }
work=${HDRSTEREO_FUZZ_WORK:-$(mktemp -d "/tmp/hdrstereo-fuzz-$target.XXXXXX")}
mkdir -p "$work/corpus" "$work/crashes"

# The same decode limits as the replay tests (tests/fuzz/CMakeLists.txt).
export OPENCV_IO_MAX_IMAGE_WIDTH=65536 OPENCV_IO_MAX_IMAGE_HEIGHT=65536
export OPENCV_IO_MAX_IMAGE_PIXELS=16777216

# Real files from other labs and cameras (../shared/data) that suit the
# target: read as seeds, never copied into the committed corpus.
data=$root/../shared/data
real=()
[[ ${HDRSTEREO_FUZZ_MERGE:-0} == 1 ]] || case $target in
  exif_fuzzer) real=("$data/unis-bracket-jpeg" "$data/raw-dng-canon550d") ;;
  raw_metadata_fuzzer) real=("$data/raw-dng-canon550d" "$data/unis-bracket-jpeg") ;;
  rgbe_fuzzer) real=("$data/debevec-memorial-church/reference-radiance.hdr") ;;
  gphoto2_dump_fuzzer) real=("$data/gphoto2-config-dumps/cameras") ;;
esac
seeds=("$fuzz_dir/corpus/$target")
for r in "${real[@]}"; do
  if [[ -e $r ]]; then
    # libFuzzer takes directories as corpora: link single files into one.
    if [[ -f $r ]]; then
      mkdir -p "$work/real"
      ln -sf "$r" "$work/real/"
      r=$work/real
    fi
    seeds+=("$r")
  else
    echo "run.sh: no $r (real seeds skipped)" >&2
  fi
done
dict=()
[[ -f $fuzz_dir/dict/$target.dict ]] && dict=(-dict="$fuzz_dir/dict/$target.dict")

log=$work/fuzz.log
status=0
# Real camera files are megabytes: let inputs be as long as the largest
# seed, but have mutations start from small ones first (libFuzzer's default).
"$binary" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2560 \
  -print_final_stats=1 -artifact_prefix="$work/crashes/" "${dict[@]}" "$@" \
  "$work/corpus" "${seeds[@]}" >"$log" 2>&1 || status=$?

executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
coverage=$(grep -o 'cov: [0-9]* ft: [0-9]*' "$log" | tail -1 || true)
echo "$target: ${executions:-?} executions in ${seconds} s, ${coverage:-no coverage line}, corpus $(ls "$work/corpus" | wc -l) new inputs"
if ((status != 0)); then
  echo "run.sh: $target FAILED (exit $status); the end of its log:" >&2
  tail -n 60 "$log" >&2
  for crash in "$work"/crashes/*; do
    [[ -f $crash ]] || continue
    echo "reproducer $crash ($(stat -c %s "$crash") bytes), base64 (first 4 kB):" >&2
    head -c 4096 "$crash" | base64 >&2
    echo "replay: $binary $crash" >&2
  done
  echo "run.sh: work folder $work" >&2
  exit 1
fi

if [[ ${HDRSTEREO_FUZZ_MERGE:-0} == 1 ]]; then
  merged=$work/merged
  mkdir -p "$merged"
  "$binary" -merge=1 "$merged" "$fuzz_dir/corpus/$target" "$work/corpus" \
    >>"$log" 2>&1
  rm -rf "$fuzz_dir/corpus/$target"
  mv "$merged" "$fuzz_dir/corpus/$target"
  echo "$target: committed corpus now $(ls "$fuzz_dir/corpus/$target" | wc -l) inputs"
fi
[[ -n ${HDRSTEREO_FUZZ_WORK:-} ]] || rm -rf "$work"
