#!/usr/bin/env bash
# Daemon overhead of a full structured-light capture: 168 frames of
# the lab-lamp scene at 1200x900, 16-bit TIFF, 1024x768 projector, with the
# simulated devices instant (--sim-time-scale 0: frames per second) and in
# real time (1: overhead against realistic hardware time). The capture job
# times its device calls and reports the rest as its own overhead in its
# last info event, which this script prints.
#
# With --watchers N the daemon serves TLS (certificates from
# deploy/make-certs.sh in the temporary folder) and every capture runs
# twice, first unwatched, then followed by N concurrent TLS clients
# (`hdrstereo jobs watch`, one process and connection each), so that the two
# overhead figures can be compared.
#
# With --http-watchers N the daemon also serves HTTP on loopback and the
# second capture is followed by N concurrent `curl` processes instead, each
# its own connection running the Server-Sent Events form of Jobs/Watch with
# an API key (as a browser page follows a capture); the script checks that
# all of them got the same complete stream, the end included.
# With --sim-camera ptpip the simulated camera is served over PTP/IP on
# loopback (16-bit TIFF) and driven through libgphoto2 (issue 38).
# Usage: tests/bench/capture_overhead.sh [BUILD_DIR]
#            [--watchers N | --http-watchers N] [--scales "0 1"]
#            [--sim-camera direct|ptpip]
set -euo pipefail
build=build
watchers=0
http_watchers=0
scales="0 1"
sim_camera=direct
while [[ $# -gt 0 ]]; do
  case "$1" in
    --watchers) watchers=$2; shift 2 ;;
    --http-watchers) http_watchers=$2; shift 2 ;;
    --scales) scales=$2; shift 2 ;;
    --sim-camera) sim_camera=$2; shift 2 ;;
    *) build=$1; shift ;;
  esac
done
if [[ $watchers -gt 0 && $http_watchers -gt 0 ]]; then
  echo "give --watchers or --http-watchers, not both" >&2
  exit 2
fi
build=$(realpath "$build")
root_dir=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$work"' EXIT

tls=()
cli_tls=()
listen=127.0.0.1:0
if [[ $watchers -gt 0 ]]; then
  certs="$work/certs"
  "$root_dir/deploy/make-certs.sh" "$certs" ca >/dev/null
  "$root_dir/deploy/make-certs.sh" "$certs" server localhost 127.0.0.1 >/dev/null
  "$root_dir/deploy/make-certs.sh" "$certs" client bench >/dev/null
  tls=(--tls-cert "$certs/server.pem" --tls-key "$certs/server.key"
       --tls-client-ca "$certs/ca.pem" --auth-user bench=operator)
  cli_tls=(--tls-ca "$certs/ca.pem" --tls-cert "$certs/bench.pem"
           --tls-key "$certs/bench.key")
  listen=0.0.0.0:0
fi
http=()
if [[ $http_watchers -gt 0 ]]; then
  http=(--http-listen 127.0.0.1:0 --auth-user bench=operator)
fi

# One capture in session $2 of the daemon at $1; $3 watchers follow it:
# TLS clients, or, given $4 (the HTTP edge's base URL), HTTP clients (SSE,
# the API key's Authorization header read from a file, so that no command
# line shows it), whose outputs must all be the same complete stream.
capture() {
  local cli=("$build/clients/cli/hdrstereo" --server "$1" "${cli_tls[@]}")
  local job
  job=$("${cli[@]}" --json capture sl "$2" | sed -n 's/^ *"id": "\([0-9]*\)".*/\1/p')
  local watchers=() watcher i
  for i in $(seq "$3"); do
    if [[ -n ${4:-} ]]; then
      curl -sSN -H @"$work/auth-header" -H 'Content-Type: application/json' \
        -H 'Accept: text/event-stream' -d "{\"jobId\": \"$job\"}" \
        "$4/hdrstereo.v1.Jobs/Watch" >"$work/http-watcher-$i" 2>&1 &
    else
      "${cli[@]}" jobs watch "$job" >/dev/null 2>&1 &
    fi
    watchers+=($!)
  done
  "${cli[@]}" jobs watch "$job" | grep "in the daemon"
  for watcher in "${watchers[@]}"; do wait "$watcher"; done
  if [[ -n ${4:-} ]]; then
    local same=0 first="$work/http-watcher-1"
    for i in $(seq "$3"); do
      cmp -s "$first" "$work/http-watcher-$i" && same=$((same + 1))
    done
    grep -q '^event: end$' "$first" || same=0
    echo "$same of $3 HTTP watchers got the whole stream, the same" \
      "$(grep -c '^data: ' "$first") messages (the end included)"
  fi
}

for scale in $scales; do
  root="$work/d$scale"
  mkdir -p "$root"
  "$build/daemon/hdrstereod" --listen "$listen" --data-root "$root" \
    --ready-file "$root/ready" --sim-time-scale "$scale" "${tls[@]}" \
    --sim-camera "$sim_camera" --sim-camera-format tiff16 \
    "${http[@]}" >"$root/log" 2>&1 &
  pid=$!
  for _ in $(seq 100); do [[ -s "$root/ready" ]] && break; sleep 0.1; done
  address=$(head -n 1 "$root/ready" | sed 's/^0\.0\.0\.0:/127.0.0.1:/')
  cli=("$build/clients/cli/hdrstereo" --server "$address" "${cli_tls[@]}")
  "${cli[@]}" hw camera set --exposure 1/60 --format tiff16 >/dev/null
  "${cli[@]}" session create sl >/dev/null
  start=$(date +%s.%N)
  echo -n "time scale $scale, unwatched: "
  capture "$address" sl 0
  end=$(date +%s.%N)
  echo "time scale $scale: $(echo "$end - $start" | bc) s wall for 168 frames"
  if [[ $watchers -gt 0 ]]; then
    "${cli[@]}" session create watched >/dev/null
    echo -n "time scale $scale, $watchers TLS watchers: "
    capture "$address" watched "$watchers"
  fi
  if [[ $http_watchers -gt 0 ]]; then
    url=$(grep '^http' "$root/ready" | head -n 1)
    key=$("${cli[@]}" admin key create --user bench --role operator 2>/dev/null)
    (umask 077; echo "Authorization: Bearer $key" >"$work/auth-header")
    "${cli[@]}" session create watched >/dev/null
    echo -n "time scale $scale, $http_watchers HTTP watchers: "
    capture "$address" watched "$http_watchers" "$url"
  fi
  kill -TERM $pid
  wait $pid
done
