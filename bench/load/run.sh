#!/usr/bin/env bash
# Load benchmark for `glam serve` (not a test): 10 parallel uploads + 100 status polls/s +
# 2 SSE followers for DURATION seconds on loopback while the server maps the uploaded jobs.
# Prints upload / poll latency percentiles and error counts (target: no errors, p99 status
# latency < 50 ms while mapping).
#
# usage: bench/load/run.sh [BUILD_DIR] [DURATION_S] [VIDEO]
#   BUILD_DIR  build tree with server/glam and tests/server/glam_loadtest (default: build)
#   DURATION_S seconds of polling (default 120)
#   VIDEO      video to upload (default: a 300-frame 640x360 synthetic clip rendered once)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build="${1:-$root/build}"
duration="${2:-120}"
video="${3:-}"
glam="$build/server/glam"
loadtest="$build/tests/server/glam_loadtest"
for bin in "$glam" "$loadtest"; do
  [[ -x "$bin" ]] || { echo "missing $bin (build targets glam and glam_loadtest)" >&2; exit 2; }
done

work="$(mktemp -d /tmp/glam_load.XXXXXX)"
source "$here/server.sh"
trap 'stop_server; rm -rf "$work"' EXIT

if [[ -z "$video" ]]; then
  clip="$build/fixtures/load_clip"
  "$glam" --log-level warn synth --trajectory lawnmower --frames 300 --width 640 --height 360 \
    --altitude 100 --seed 5 --out "$clip"
  video="$clip/video.mp4"
fi
echo "video: $video ($(stat -c %s "$video") bytes), duration ${duration}s, $(nproc) cores"

start_server "$glam" "$work" --max-queued-jobs 100

status=0
"$loadtest" --port "$port" --video "$video" --uploads 10 --poll-rate 100 --poll-threads 4 \
  --sse-clients 2 --duration "$duration" || status=$?
echo "server metrics (excerpt):"
curl -s "http://127.0.0.1:$port/api/v1/metrics" | grep -E '^glam_(jobs|frames_processed_total)' || true
kill -TERM "$server_pid"
wait "$server_pid" && echo "server exited cleanly" || echo "server exit status $?"
server_pid=""
exit "$status"
