#!/usr/bin/env bash
# A live stream against its file: a synthetic flight is sent in real time over UDP (ffmpeg -re,
# MPEG-TS, as a ground station relays a drone's feed) to `glam map udp://...`, and mapped from
# the file too. Prints, for both: frames decoded / dropped / posed, ATE and map median; for the
# stream also how long after the last frame was sent the map was written (minus the stall
# timeout that tells glam map the stream ended). Where mapping is slower than the stream's frame
# rate (1280x720 on 2 cores), frames are dropped (engine/video/stream_source.h).
# Usage: bench/live_stream.sh [BUILD_DIR] [WIDTH] [FRAMES]   (defaults: build, 1280, 600)
#   REUSE_VIDEO=1 keeps an earlier render of the same size; LIVE_ARGS="--stream-buffer 2" adds
#   options to the live run only.
# Numbers go to docs/benchmarks.md by hand.
set -euo pipefail
BUILD_DIR="${1:-build}"
WIDTH="${2:-1280}"
FRAMES="${3:-600}"
HEIGHT=$((WIDTH * 9 / 16))
GLAM="$BUILD_DIR/server/glam"
WORK="out/bench/live_stream_${WIDTH}_${FRAMES}"
PORT="${PORT:-5004}"
STALL_S=3
mkdir -p "$WORK"

if [[ "${REUSE_VIDEO:-0}" != 1 || ! -f "$WORK/gt/video.mp4" ]]; then
  "$GLAM" --log-level warn synth --trajectory lawnmower --frames "$FRAMES" --width "$WIDTH" \
    --height "$HEIGHT" --altitude 100 --seed 3 --out "$WORK/gt"
fi
ffmpeg -nostdin -loglevel error -y -i "$WORK/gt/video.mp4" -c copy -f mpegts "$WORK/feed.ts"

# The file.
"$GLAM" --log-level warn map "$WORK/gt/video.mp4" --intrinsics "$WORK/gt/intrinsics.json" \
  --out "$WORK/map_file" > /dev/null
"$GLAM" --log-level warn eval --gt "$WORK/gt" --result "$WORK/map_file" --json "$WORK/eval_file.json" > /dev/null

# The stream: glam map listens on UDP, then the sender starts at the video's own pace.
rm -rf "$WORK/map_live"
"$GLAM" --log-level info map "udp://127.0.0.1:$PORT?fifo_size=1000000&overrun_nonfatal=1" \
  --intrinsics "$WORK/gt/intrinsics.json" --stream-timeout "$STALL_S" --out "$WORK/map_live" \
  ${LIVE_ARGS:-} > "$WORK/live.log" 2>&1 &
mapper=$!
sleep 1
send_start=$(date +%s.%N)
ffmpeg -nostdin -loglevel error -re -i "$WORK/feed.ts" -c copy -f mpegts "udp://127.0.0.1:$PORT?pkt_size=1316"
send_end=$(date +%s.%N)
wait "$mapper"
map_end=$(date +%s.%N)
"$GLAM" --log-level warn eval --gt "$WORK/gt" --result "$WORK/map_live" --json "$WORK/eval_live.json" > /dev/null

python3 - "$WORK" "$send_start" "$send_end" "$map_end" "$STALL_S" "$WIDTH" "$HEIGHT" <<'PY'
import json, sys
work, s0, s1, m1, stall, w, h = sys.argv[1], *map(float, sys.argv[2:5]), float(sys.argv[5]), sys.argv[6], sys.argv[7]
print(f"live stream benchmark, {w}x{h}, sent over UDP in {s1 - s0:.1f} s")
for run in ("file", "live"):
    r = json.load(open(f"{work}/map_{run}/report.json"))
    e = json.load(open(f"{work}/eval_{run}.json"))
    tr, m = e["trajectory"], e.get("map") or {}
    print(f"{run:5s}: decoded {r['frames_decoded']}, dropped {r.get('frames_dropped', 0)}, posed "
          f"{r['frames_posed']} ({100 * tr['fraction_posed']:.1f} % of the flight), "
          f"ATE {tr['ate_rmse_m']:.3f} m, map median {m.get('median_m', float('nan')):.3f} m, "
          f"{r['points']} points, {r['submaps']} submaps, processing {r['processing_fps']:.1f} fps")
print(f"map written {m1 - s1 - stall:.1f} s after the last frame was sent "
      f"(plus the {stall:.0f} s without frames that ends the stream)")
PY
