#!/usr/bin/env bash
# Clang's thread-safety analysis over the daemon, whose shared state is
# annotated (ABSL_GUARDED_BY, ABSL_EXCLUSIVE_LOCKS_REQUIRED, scoped locks):
# the store's connection lock and transactions, the job engine, the
# scheduler, the rig lock, the audit log and the API key cache.
# It reuses a configured build's compile_commands.json and only parses (clang
# -fsyntax-only), so it costs minutes, not a second build. It first checks
# that the analysis is live: tests/static/thread_safety_violation.cc, which
# prepares a statement without the connection's lock, must be rejected.
# Usage: deploy/check-thread-safety.sh [BUILD_DIR]   (default: build; ctest
# runs it as the test thread_safety_analysis)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=$(cd "${1:-$root/build}" && pwd)
commands="$build_dir/compile_commands.json"
[[ -f "$commands" ]] || {
  echo "check-thread-safety: $commands is missing; run deploy/build.sh first" >&2
  exit 2
}
clang=$(command -v clang++ || true)
[[ -n "$clang" ]] || {
  echo "check-thread-safety: clang++ is missing; run deploy/setup-deps.sh" >&2
  exit 2
}

# One line per daemon source: the GCC command with its warning flags, output
# and compiler replaced, NUL-separated arguments.
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 - "$commands" "$root" "$work" <<'PY'
import json, os, shlex, sys
commands, root, work = sys.argv[1:]
analysis = ["-fsyntax-only", "-Wno-everything", "-Wthread-safety",
            "-Werror=thread-safety"]
n = 0
for entry in json.load(open(commands)):
    source = os.path.relpath(entry["file"], root)
    if not source.startswith("daemon/") or not source.endswith(".cc"):
        continue
    args = entry.get("arguments") or shlex.split(entry["command"])
    kept, skip = [], False
    for a in args[1:]:
        if skip:
            skip = False
            continue
        if a in ("-o", "-MF", "-MT", "-MQ"):
            skip = True
            continue
        if a.startswith("-W") or a in ("-c", "-MD", "-MMD"):
            continue
        kept.append(a)
    if args[0].endswith("ccache"):  # launcher, then the compiler
        kept = kept[1:]
    with open(os.path.join(work, f"{n:04d}.args"), "w") as f:
        f.write("\0".join(["-working-directory", entry["directory"]] + kept +
                          analysis))
    n += 1
# The probe: compiled like the store, it must fail.
store = next(e for e in json.load(open(commands))
             if e["file"].endswith("daemon/store/database.cc"))
args = store.get("arguments") or shlex.split(store["command"])
flags = [a for a in args[1:] if a.startswith(("-I", "-isystem", "-D", "-std"))]
with open(os.path.join(work, "probe.args"), "w") as f:
    f.write("\0".join(flags + [os.path.join(root, "tests/static/thread_safety_violation.cc")] + analysis))
print(f"check-thread-safety: {n} daemon sources", file=sys.stderr)
PY

if xargs -0 -a "$work/probe.args" "$clang" 2>"$work/probe.log"; then
  echo "check-thread-safety: the probe compiled; the analysis is not live" >&2
  exit 1
fi
grep -q "requires holding mutex" "$work/probe.log" || {
  echo "check-thread-safety: the probe failed for another reason:" >&2
  cat "$work/probe.log" >&2
  exit 1
}

failed=0
for args in "$work"/0*.args; do
  echo "$args"
done | xargs -P "$(nproc)" -I{} sh -c \
  'xargs -0 -a "$1" "$2" || { echo "check-thread-safety: FAILED: $(tr "\0" " " < "$1" | grep -o "[^ ]*daemon/[^ ]*\.cc" | tail -1)" >&2; exit 1; }' \
  _ {} "$clang" || failed=1
if ((failed)); then
  echo "check-thread-safety: thread-safety violations above" >&2
  exit 1
fi
echo "check-thread-safety: ok"
