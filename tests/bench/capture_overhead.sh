#!/usr/bin/env bash
# Daemon overhead of a full structured-light capture (issue 5): 168 frames of
# the lab-lamp scene at 1200x900, 16-bit TIFF, 1024x768 projector, with the
# simulated devices instant (--sim-time-scale 0: frames per second) and in
# real time (1: overhead against realistic hardware time). The capture job
# times its device calls and reports the rest as its own overhead in its
# last info event, which this script prints.
# Usage: tests/bench/capture_overhead.sh [BUILD_DIR]
set -euo pipefail
build=$(realpath "${1:-build}")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for scale in 0 1; do
  root="$work/d$scale"
  mkdir -p "$root"
  "$build/daemon/hdrstereod" --listen 127.0.0.1:0 --data-root "$root" \
    --ready-file "$root/ready" --sim-time-scale "$scale" >"$root/log" 2>&1 &
  pid=$!
  for _ in $(seq 100); do [[ -s "$root/ready" ]] && break; sleep 0.1; done
  cli=("$build/clients/cli/hdrstereo" --server "$(cat "$root/ready")")
  "${cli[@]}" hw camera set --exposure 1/60 --format tiff16 >/dev/null
  "${cli[@]}" session create sl >/dev/null
  start=$(date +%s.%N)
  "${cli[@]}" capture sl sl --watch | grep "in the daemon"
  end=$(date +%s.%N)
  echo "time scale $scale: $(echo "$end - $start" | bc) s wall for 168 frames"
  kill -TERM $pid
  wait $pid
done
