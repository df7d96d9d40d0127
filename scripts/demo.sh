#!/usr/bin/env bash
# The demo behind `make run`: starts the mapping server (`glam serve`) and runs one job on a
# built-in sample — a short synthetic drone flight rendered by `glam synth` with exact ground
# truth — through the REST API exactly as a user would: upload with curl, follow progress,
# download the results, evaluate them against the ground truth. The server keeps running
# afterwards (Ctrl-C stops it; `DEMO_EXIT=1` exits instead). Re-running skips the render.
#   PORT (default 8080), OUT (default out/demo)
set -euo pipefail
BUILD_DIR="${1:-build}"
GLAM="$BUILD_DIR/server/glam"
OUT="${OUT:-out/demo}"
PORT="${PORT:-8080}"
API="http://127.0.0.1:$PORT/api/v1"
mkdir -p "$OUT"

echo "== 1/5 rendering the sample: a 300-frame lawnmower flight (640x360, 100 m altitude) with its GPS track"
"$GLAM" synth --trajectory lawnmower --frames 300 --width 640 --height 360 --altitude 100 \
  --seed 1 --gps-noise 1.5 --out "$OUT/gt"

echo "== 2/5 starting the server: glam serve --data $OUT/data --port $PORT"
"$GLAM" serve --data "$OUT/data" --port "$PORT" > "$OUT/serve.out" 2> "$OUT/serve.log" &
SERVER=$!
trap 'kill "$SERVER" 2>/dev/null || true; wait "$SERVER" 2>/dev/null || true' EXIT
for _ in $(seq 1 100); do
  curl -sf "$API/health" > /dev/null && break
  kill -0 "$SERVER" 2>/dev/null || { echo "the server did not start:"; cat "$OUT/serve.log"; exit 1; }
  sleep 0.1
done
curl -sf "$API/health" > /dev/null || { echo "the server does not answer on port $PORT"; exit 1; }

echo "== 3/5 uploading: curl -F video=@$OUT/gt/video.mp4 -F telemetry=@$OUT/gt/video.SRT -F options=... $API/jobs"
OPTIONS=$(jq -c '{name: "demo: synthetic lawnmower", keyframes_per_submap: 6, intrinsics: .}' \
  "$OUT/gt/intrinsics.json")
JOB=$(curl -sf -F "video=@$OUT/gt/video.mp4;type=video/mp4" -F "telemetry=@$OUT/gt/video.SRT" \
  -F "options=$OPTIONS" "$API/jobs")
ID=$(jq -r .id <<< "$JOB")
echo "job $ID queued; map view: http://127.0.0.1:$PORT/?job=$ID"

echo "== 4/5 mapping (progress from GET $API/jobs/$ID)"
while true; do
  STATUS=$(curl -sf "$API/jobs/$ID")
  STATE=$(jq -r .state <<< "$STATUS")
  jq -r '"  \(.state): \(.progress.frames_done)/\(.progress.frames_total) frames, \(.progress.fps|floor) fps, submaps \(.progress.submaps_completed) (aligned \(.progress.submaps_aligned)), revision \(.progress.revision)"' <<< "$STATUS"
  case "$STATE" in
    completed) break ;;
    failed|canceled) echo "job $STATE: $(jq -r .error <<< "$STATUS")"; exit 1 ;;
  esac
  sleep 2
done

echo "== 5/5 downloading the results and evaluating them against the ground truth"
mkdir -p "$OUT/result"
for f in trajectory.tum points.ply report.json graph.json; do
  curl -sf -o "$OUT/result/$f" "$API/jobs/$ID/$f"
done
jq -r '.georeference | if . == null then "not georeferenced" elif .ok then
  "georeferenced by the GPS track: metres, east-north-up around \(.origin.latitude), \(.origin.longitude) (\(.samples_used) positions, rms \(.rms_m * 100 | round / 100) m)"
  else "not georeferenced: \(.reason)" end' "$OUT/result/report.json"
"$GLAM" eval --gt "$OUT/gt" --result "$OUT/result" --json "$OUT/eval.json"
echo "Results: $OUT/result (trajectory.tum, points.ply, report.json, graph.json); metrics: $OUT/eval.json"

if [[ "${DEMO_EXIT:-0}" == "1" ]]; then exit 0; fi
echo "The server keeps running at http://127.0.0.1:$PORT/ (API at $API); Ctrl-C stops it."
wait "$SERVER"
