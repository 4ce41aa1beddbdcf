#!/usr/bin/env bash
# The main job of AVATAR/TAU on the embedded default (README command 1):
# TAUNet replays the bundled lab session, a TAUUnit client (tautui in script
# mode) takes a snapshot, prints the targets (type, 3-D position in the vision
# and manipulator base frames, pixel centroids) and saves the marked images;
# then the daemon is stopped with SIGTERM and must exit cleanly.
#
#   bash tools/scripts/main-job.sh [BUILD_DIR [OUT_DIR]]
#
# BUILD_DIR defaults to build/, OUT_DIR (marked images, daemon log) to
# BUILD_DIR/demo. Exits non-zero when any step fails. The test suite runs
# this script too (test main_job), so command 1 stays working.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
out=${2:-$build/demo}
session="$root/data/sessions/lab"
taunet="$build/tau/net/taunet"
tautui="$build/tau/tui/tautui"

for exe in "$taunet" "$tautui"; do
  if [ ! -x "$exe" ]; then
    echo "main-job: $exe is missing; build first (cmake --build $build)" >&2
    exit 1
  fi
done
mkdir -p "$out"

daemon_out="$out/taunet.stdout"
daemon_log="$out/taunet.log"
: >"$daemon_out"

# The daemon on a port the system chooses; it prints "listening on HOST:PORT".
"$taunet" --backend replay --session "$session" --port 0 --log info \
    >"$daemon_out" 2>"$daemon_log" &
daemon=$!
stop_daemon() {
  if kill -0 "$daemon" 2>/dev/null; then kill -TERM "$daemon" 2>/dev/null || true; fi
}
trap stop_daemon EXIT

port=""
for _ in $(seq 1 200); do  # up to 10 s
  if ! kill -0 "$daemon" 2>/dev/null; then
    echo "main-job: taunet exited before listening; its log ($daemon_log):" >&2
    cat "$daemon_log" >&2
    exit 1
  fi
  port=$(sed -n 's/^listening on .*:\([0-9][0-9]*\)$/\1/p' "$daemon_out")
  [ -n "$port" ] && break
  sleep 0.05
done
if [ -z "$port" ]; then
  echo "main-job: taunet did not report its port within 10 s; its log ($daemon_log):" >&2
  cat "$daemon_log" >&2
  exit 1
fi
echo "== TAUNet replays $session on 127.0.0.1:$port (log: $daemon_log)"

echo "== TAUUnit client (tautui script): snapshot, targets, marked images"
"$tautui" --port "$port" --out "$out" <<'EOF'
status
snapshot
images marked
iterations
EOF

echo "== stopping TAUNet (SIGTERM)"
kill -TERM "$daemon"
status=0
wait "$daemon" || status=$?
trap - EXIT
if [ "$status" -ne 0 ]; then
  echo "main-job: taunet exited with status $status; its log ($daemon_log):" >&2
  tail -20 "$daemon_log" >&2
  exit 1
fi
echo "== done: TAUNet stopped cleanly; marked images in $out"
