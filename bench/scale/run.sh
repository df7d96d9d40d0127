#!/usr/bin/env bash
# Scale run of issue 8: one long synthetic lawnmower flight (default 20,000 frames, 640x360,
# 100 m altitude, seed 11 — a seed no test uses) through `glam map`, sampling the mapper's
# resident memory (/proc/PID/status VmRSS) and its progress (frames done, from the progress
# lines `glam map` logs) and CPU time (utime + stime of /proc/PID/stat, and of each thread in
# /proc/PID/task) every few seconds.
# Throughput is reported both per wall second and per CPU second: the machine is shared, and
# frames per CPU second is the measure that other processes' load does not distort. Writes
# out/bench/scale/<FRAMES>/{samples.tsv,threads.tsv}, prints a summary (bench/scale/summarize.py)
# and draws docs/images/bench/scale_fps_rss.png.
# Usage: bench/scale/run.sh [BUILD_DIR] [FRAMES]   (defaults: build, 20000)
#   REUSE_VIDEO=1: map the flight rendered by an earlier run again (rendering takes ~15 min).
# Runs under `nice -n 10`; takes about an hour on 2 cores (render + map).
set -euo pipefail
# Debian's python3 (numpy, matplotlib from bench/colmap/setup.sh), not a pyenv/venv one.
PY="${PYTHON:-/usr/bin/python3}"
BUILD_DIR="${1:-build}"
FRAMES="${2:-20000}"
GLAM="$(realpath "$BUILD_DIR/server/glam")"
HERE="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
WORK="$ROOT/out/bench/scale/$FRAMES"
INTERVAL="${SAMPLE_INTERVAL:-5}"
mkdir -p "$WORK"
cd "$ROOT"

echo "commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown), $(nproc) cores" | tee "$WORK/machine.txt"

if [ "${REUSE_VIDEO:-0}" = 1 ] && [ -f "$WORK/gt/video.mp4" ] && [ -f "$WORK/gt/synth.json" ]; then
  echo "reusing the rendered flight in $WORK/gt (REUSE_VIDEO=1)"
else
  synth_start=$(date +%s)
  nice -n 10 "$GLAM" --log-level warn synth --trajectory lawnmower --frames "$FRAMES" --width 640 \
    --height 360 --altitude 100 --seed 11 --crf 20 --out "$WORK/gt"
  echo "synth_seconds $(( $(date +%s) - synth_start ))" | tee "$WORK/synth_time.txt"
fi
ls -l "$WORK/gt/video.mp4"

rm -rf "$WORK/map"
start=$(date +%s.%N)
nice -n 10 "$GLAM" --log-level info map "$WORK/gt/video.mp4" --intrinsics "$WORK/gt/intrinsics.json" \
  --out "$WORK/map" > "$WORK/map.log" 2>&1 &
PID=$!
printf 't_s\trss_mb\tframes_done\tsubmaps\tcpu_s\n' > "$WORK/samples.tsv"
# Per thread (the engine names its threads: glam-decode, glam-sift, glam-align; the builder is
# the main thread, is_main 1): which stage's CPU per frame grows is what the flight's length
# costs.
printf 't_s\tframes_done\ttid\tis_main\tname\tcpu_s\n' > "$WORK/threads.tsv"
TICKS=$(getconf CLK_TCK)
while kill -0 "$PID" 2>/dev/null; do
  rss=$(awk '/^VmRSS/ {print $2}' "/proc/$PID/status" 2>/dev/null || true)
  line=$(grep -a -o '[0-9]*/[0-9]* frames .*submaps [0-9]*' "$WORK/map.log" | tail -n 1 || true)
  done_frames=$(echo "$line" | sed -n 's#^\([0-9]*\)/.*#\1#p')
  submaps=$(echo "$line" | sed -n 's#.*submaps \([0-9]*\).*#\1#p')
  # Fields 14 and 15 of /proc/PID/stat (after the parenthesised command name).
  cpu=$(sed 's/^.*) //' "/proc/$PID/stat" 2>/dev/null | awk -v hz="$TICKS" '{print ($12 + $13) / hz}' || true)
  now=$(date +%s.%N)
  [ -n "$rss" ] && [ -n "$cpu" ] && printf '%.1f\t%.1f\t%s\t%s\t%s\n' "$(echo "$now - $start" | bc)" \
    "$(echo "$rss / 1024" | bc -l)" "${done_frames:-0}" "${submaps:-0}" "$cpu" >> "$WORK/samples.tsv"
  for task in /proc/"$PID"/task/*; do
    stat=$(cat "$task/stat" 2>/dev/null) || continue
    name=$(cat "$task/comm" 2>/dev/null) || continue
    read -ra f <<< "${stat##*) }"
    printf '%.1f\t%s\t%s\t%s\t%s\t%s\n' "$(echo "$now - $start" | bc)" "${done_frames:-0}" "${task##*/}" \
      "$([ "${task##*/}" = "$PID" ] && echo 1 || echo 0)" "$name" "$(echo "(${f[11]} + ${f[12]}) / $TICKS" | bc -l)"
  done >> "$WORK/threads.tsv"
  sleep "$INTERVAL"
done
wait "$PID"
end=$(date +%s.%N)
echo "map_wall_seconds $(echo "$end - $start" | bc)" | tee "$WORK/map_time.txt"

nice -n 10 "$GLAM" --log-level warn eval --gt "$WORK/gt" --result "$WORK/map" --json "$WORK/eval.json" || true
"$PY" "$HERE/summarize.py" "$WORK" "$ROOT/docs/images/bench/scale_fps_rss.png"
