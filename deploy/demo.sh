#!/usr/bin/env bash
# The main job on the embedded defaults: builds, starts hdrstereod with
# simulated hardware (the lab-lamp scene) and a local data root, creates a
# session, runs a bracketed stereo capture (the thesis' 8 exposures, 150 mm)
# and a structured-light capture with live progress, processes the session
# (HDR, seven tone-mapped pairs, stereo, fusion, structured-light ground
# truth, metrics, Middlebury export, HTML report), prints the metrics table
# and the report's path, and stops the daemon cleanly. With --console it
# then keeps the daemon running and prints the operator's console URL and
# an API key file to sign in with (Ctrl-C stops it). With --ptpip the
# simulated camera is served as a PTP/IP network camera on loopback and the
# real gphoto2 driver drives it through libgphoto2 (--sim-camera ptpip).
# Usage: deploy/demo.sh [--console] [--ptpip] [DATA_ROOT]
#        (default DATA_ROOT: ./demo-data)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
console=0
sim_camera=direct
while [[ "${1:-}" == --* ]]; do
  case "$1" in
    --console) console=1 ;;
    --ptpip) sim_camera=ptpip ;;
    *) echo "usage: deploy/demo.sh [--console] [--ptpip] [DATA_ROOT]" >&2
       exit 2 ;;
  esac
  shift
done
"$root/deploy/build.sh" "$root/build"
bin="$root/build"
data_root=$(realpath -m "${1:-demo-data}")
mkdir -p "$data_root"
ready="$data_root/hdrstereod.ready"
rm -f "$ready"

echo "== starting hdrstereod (simulated hardware, camera $sim_camera, data root $data_root)"
"$bin/daemon/hdrstereod" --hardware sim --sim-camera "$sim_camera" \
  --data-root "$data_root" \
  --listen 127.0.0.1:0 --http-listen 127.0.0.1:0 --auth-user demo=admin \
  --ready-file "$ready" &
daemon=$!
trap 'kill -TERM $daemon 2>/dev/null; wait $daemon 2>/dev/null || true' EXIT
for _ in $(seq 100); do [[ -s "$ready" ]] && break; sleep 0.1; done
[[ -s "$ready" ]] || { echo "hdrstereod did not start" >&2; exit 1; }
# The ready file: the gRPC address, then the console's URL.
export HDRSTEREO_SERVER=$(sed -n 1p "$ready")
console_url=$(sed -n 2p "$ready")
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

if ((console)); then
  key_file="$data_root/demo.key"
  (umask 077 && "$cli" admin key create --user demo --role admin \
     --expires 1d --note "deploy/demo.sh --console" > "$key_file")
  echo "== the console: open $console_url and sign in with the key in"
  echo "   $key_file (shown once; an admin key for the user demo, valid 1 day)."
  echo "   Ctrl-C stops the daemon."
  wait $daemon || true
  trap - EXIT
  exit 0
fi

echo "== stopping hdrstereod"
kill -TERM $daemon
wait $daemon
trap - EXIT
echo "== done: the session (frames, Middlebury export, report/index.html) is $data_root/sessions/$session; the database is $data_root/hdrstereo.db"
