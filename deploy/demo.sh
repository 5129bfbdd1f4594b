#!/usr/bin/env bash
# The main job on the embedded defaults: builds, starts hdrstereod with
# simulated hardware (the lab-lamp scene) and a local data root, creates a
# session, runs a bracketed stereo capture (the thesis' 8 exposures, 150 mm)
# and a structured-light capture with live progress, processes the session
# (HDR, seven tone-mapped pairs, stereo, fusion, structured-light ground
# truth, metrics, Middlebury export, HTML report), prints the metrics table
# and the report's path, and stops the daemon cleanly.
# Usage: deploy/demo.sh [DATA_ROOT]   (default: ./demo-data)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/build.sh" "$root/build"
bin="$root/build"
data_root=$(realpath -m "${1:-demo-data}")
mkdir -p "$data_root"
ready="$data_root/hdrstereod.ready"
rm -f "$ready"

echo "== starting hdrstereod (simulated hardware, data root $data_root)"
"$bin/daemon/hdrstereod" --hardware sim --data-root "$data_root" \
  --listen 127.0.0.1:0 --ready-file "$ready" &
daemon=$!
trap 'kill -TERM $daemon 2>/dev/null; wait $daemon 2>/dev/null || true' EXIT
for _ in $(seq 100); do [[ -s "$ready" ]] && break; sleep 0.1; done
[[ -s "$ready" ]] || { echo "hdrstereod did not start" >&2; exit 1; }
export HDRSTEREO_SERVER=$(cat "$ready")
cli="$bin/clients/cli/hdrstereo"

echo "== hdrstereo status"
"$cli" status
session="demo-$(date +%Y%m%d-%H%M%S)"
echo "== hdrstereo session create $session"
"$cli" session create "$session" --note "created by deploy/demo.sh"
echo "== hdrstereo hw status"
"$cli" hw status
echo "== hdrstereo capture stereo $session --watch"
"$cli" capture stereo "$session" --watch
echo "== hdrstereo capture sl $session --watch"
"$cli" capture sl "$session" --watch
echo "== hdrstereo process $session --watch"
"$cli" process "$session" --watch
echo "== hdrstereo report $session"
"$cli" report "$session"
echo "== hdrstereo jobs list"
"$cli" jobs list

echo "== stopping hdrstereod"
kill -TERM $daemon
wait $daemon
trap - EXIT
echo "== done: the session (frames, Middlebury export, report/index.html) is $data_root/sessions/$session; the database is $data_root/hdrstereo.db"
