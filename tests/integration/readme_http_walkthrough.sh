#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
#
# Runs README.md's "Over HTTP" curl walkthrough as printed: starts the real
# hdrstereod (simulated hardware, the small lab-lamp scene, a temporary data
# root, gRPC and HTTP on free loopback ports, alice an operator), runs the
# README's key block (<!-- http-walkthrough-key -->, the CLI reached as
# build/clients/cli/hdrstereo like the README writes it) and then its
# walkthrough block (<!-- http-walkthrough -->) under bash -euo pipefail with
# HDR set to the edge's URL, each with a time limit, and checks what they
# printed: the sign-in, the session, the capture's SSE stream ending with
# the job succeeded, the frame's two ranges, its sha256 and byte count
# against the file in the data root, and that the key is never printed.
# The daemon is always stopped. Any failure exits 1 with the reason, the
# walkthrough's output and the daemon's log.
#
# Usage: readme_http_walkthrough.sh HDRSTEREOD HDRSTEREO_CLI
set -euo pipefail

[[ $# -eq 2 ]] || { sed -n '4,17p' "$0" >&2; exit 2; }
daemon_bin=$(realpath "$1")
cli_bin=$(realpath "$2")
source_dir=$(cd "$(dirname "$0")/../.." && pwd)
readme=$source_dir/README.md
session="readme-http"  # S for the walkthrough

work=$(mktemp -d)
daemon_pid=""
stop_daemon() {
  [[ -n "$daemon_pid" ]] || return 0
  kill -TERM "$daemon_pid" 2>/dev/null || true
  for _ in $(seq 300); do
    kill -0 "$daemon_pid" 2>/dev/null || break
    sleep 0.1
  done
  kill -KILL "$daemon_pid" 2>/dev/null || true
  wait "$daemon_pid" 2>/dev/null || true
  daemon_pid=""
}
trap 'stop_daemon; rm -rf "$work"' EXIT

fail() {
  echo "FAIL: $*" >&2
  for f in key.out key.err walkthrough.out walkthrough.err daemon.log; do
    [[ -s "$work/$f" ]] || continue
    echo "----- $f" >&2
    tail -n 80 "$work/$f" >&2
    [[ -z $(tail -c 1 "$work/$f") ]] || echo >&2  # a body without a newline
  done
  exit 1
}

for tool in curl jq sha256sum timeout; do
  command -v "$tool" >/dev/null ||
    fail "$tool is missing (deploy/setup-deps.sh installs it)"
done

# The fenced block right after the line MARKER in the README, without its
# fences.
block() {
  awk -v marker="$1" '
    $0 == marker { found = 1; next }
    found == 1 && /^```/ { found = 2; next }
    found == 2 && /^```/ { exit }
    found == 2 { print }' "$readme"
}
key_block=$(block '<!-- http-walkthrough-key -->')
walkthrough=$(block '<!-- http-walkthrough -->')
[[ -n "$key_block" ]] || fail "README.md has no <!-- http-walkthrough-key --> block"
[[ -n "$walkthrough" ]] || fail "README.md has no <!-- http-walkthrough --> block"
# shellcheck disable=SC2016  # the line as printed, not expanded
[[ $(head -n 1 <<<"$walkthrough") == 'HDR=${HDR:-http://127.0.0.1:8080}' ]] ||
  fail "the walkthrough's first line is not HDR=\${HDR:-http://127.0.0.1:8080}"

# The small lab-lamp of the other tests (tests/support/daemon_fixture.cc
# SmallLabLamp), so the capture is quick.
jq '. * {camera: {width: 240, height: 180, fx: 320, fy: 320,
                  cx: 119.5, cy: 89.5},
         projector: {width: 128, height: 96}}' \
  "$source_dir/hardware/sim/scenes/lab-lamp.json" > "$work/scene.json"

"$daemon_bin" --data-root "$work/data" --hardware sim \
  --sim-scene "$work/scene.json" --listen 127.0.0.1:0 \
  --http-listen 127.0.0.1:0 --auth-user alice=operator \
  --ready-file "$work/ready" > "$work/daemon.log" 2>&1 &
daemon_pid=$!
for _ in $(seq 600); do
  [[ -s "$work/ready" ]] && break
  kill -0 "$daemon_pid" 2>/dev/null || fail "hdrstereod exited at start"
  sleep 0.1
done
[[ -s "$work/ready" ]] || fail "hdrstereod wrote no ready file within 60 s"
# gRPC addresses, then the HTTP edge's base URLs.
grpc=$(grep -v '^http' "$work/ready" | head -n 1)
hdr=$(grep '^http://' "$work/ready" | head -n 1) ||
  fail "no HTTP address in the ready file: $(tr '\n' ' ' < "$work/ready")"

# The blocks run in a folder of their own, with an empty home (no client
# profile of whoever runs the test) and the CLI where the README has it.
run=$work/run
mkdir -p "$run/build/clients/cli" "$work/home" "$work/tmp"
ln -s "$cli_bin" "$run/build/clients/cli/hdrstereo"
clean_env=(env -u HDRSTEREO_PROFILE -u HDRSTEREO_TLS_CA -u HDRSTEREO_TLS_CERT
  -u HDRSTEREO_TLS_KEY -u HDRSTEREO_API_KEY_FILE -u HDRSTEREO_CLIENT_CONFIG
  -u XDG_CONFIG_HOME HOME="$work/home" TMPDIR="$work/tmp")

# Exits N: "exit N", or 124 past the time limit.
exited() { (($1 == 124)) && echo "it ran past $2 s" || echo "exit $1"; }

rc=0
(cd "$run" && "${clean_env[@]}" HDRSTEREO_SERVER="$grpc" \
   timeout 60 bash -euo pipefail -c "$key_block") \
  > "$work/key.out" 2> "$work/key.err" || rc=$?
((rc == 0)) || fail "the README's key block failed ($(exited $rc 60))"
key=$(cat "$run/alice.key")
[[ $key =~ ^hs_[0-9a-f]{12}_[0-9a-f]{64}$ ]] ||
  fail "alice.key holds no API key (hs_<12 hex>_<64 hex>)"
[[ $(stat -c %a "$run/alice.key") == 600 ]] ||
  fail "alice.key is mode $(stat -c %a "$run/alice.key"), not 600"

(cd "$run" && "${clean_env[@]}" HDR="$hdr" S="$session" \
   timeout 180 bash -euo pipefail -c "$walkthrough") \
  > "$work/walkthrough.out" 2> "$work/walkthrough.err" || rc=$?
((rc == 0)) || fail "the README's walkthrough failed ($(exited $rc 180))"
out=$(cat "$work/walkthrough.out")

# What it printed, in order.
expect() {  # expect REGEX WHAT: a line of the output matches REGEX
  grep -Eq -- "$1" <<<"$out" || fail "the walkthrough did not print $2"
}
head -n 1 <<<"$out" | jq -e '.user == "alice" and .role == "operator"' \
  > /dev/null 2>&1 || fail "the walkthrough did not print alice's sign-in first"
expect "^\\{\"name\":\"$session\"" "the session it created"
expect "^$session\$" "the session in the list"
expect '^capture job [0-9]+$' "the capture job's id"
# The SSE stream: events, the last one the job succeeded, then its end.
sse=$(grep -E '^(data|event):' <<<"$out")
[[ $(tail -n 3 <<<"$sse" | head -n 1) == *'"state":"JOB_STATE_SUCCEEDED"'* ]] ||
  fail "the SSE stream's last event is not the job succeeded"
[[ $(tail -n 2 <<<"$sse") == $'event: end\ndata: {}' ]] ||
  fail "the SSE stream did not end with event: end / data: {}"
expect '^JOB_STATE_SUCCEEDED$' "the job's final state from Jobs/Get"

# The frame: the first KiB (206, its ETag the sha256), then the rest.
file=$(grep -Eo '^[^ ]+: OK$' <<<"$out" | head -n 1 | sed 's/: OK$//') ||
  fail "sha256sum -c did not print OK for the frame"
sha=$(grep -Eo '^206 bytes 0-1023/[0-9]+ ETag "[0-9a-f]{64}"$' <<<"$out" |
      sed -E 's/.*"([0-9a-f]{64})"$/\1/') ||
  fail "the first range was not 206 bytes 0-1023/N with the sha256 as ETag"
total=$(grep -Eo '^206 bytes 0-1023/[0-9]+' <<<"$out" | sed 's|.*/||')
expect "^206 bytes 1024-$((total - 1))/$total\$" "the resumed rest (206)"
expect "^$total $file\$" "the downloaded byte count ($total)"
# Views share file names: the frame is the one whose sha256 is the ETag.
on_disk=""
while IFS= read -r candidate; do
  [[ $(sha256sum < "$candidate" | cut -d' ' -f1) == "$sha" ]] &&
    on_disk=$candidate
done < <(find "$work/data/sessions/$session" -type f -name "$file")
[[ -n "$on_disk" ]] ||
  fail "no frame $file with the ETag's sha256 in the session's folder"
cmp -s "$on_disk" "$run/$file" ||
  fail "the downloaded $file differs from $on_disk"
expect '^\{\}$' "the sign-out's {}"

# The key never shows in what the walkthrough printed, nor in the log.
grep -qF -- "$key" "$work/walkthrough.out" "$work/walkthrough.err" &&
  fail "the API key appears in the walkthrough's output"
grep -qF -- "${key##*_}" "$work/daemon.log" "$work/key.out" "$work/key.err" &&
  fail "the API key's secret appears in the daemon's log or the key block's output"

stop_daemon
echo "README walkthrough ran as printed: session $session, $file" \
     "($total bytes), job succeeded"
