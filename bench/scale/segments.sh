#!/usr/bin/env bash
# Separates content from growth in the throughput decay of a scale run: cuts tenths of the
# run's video (default the first and the last) into short clips, maps each in a fresh
# `glam map` process, and prints each tenth's throughput fresh beside its throughput inside the
# long run (from samples.tsv). If a tenth is as slow fresh as inside the run, its slowness is
# the content (terrain texture, turns), not state that grew during the flight; what is left of
# the decay after dividing out the fresh rates is what the flight's length costs.
# Usage: bench/scale/segments.sh [BUILD_DIR] [FRAMES] [TENTHS...]   (defaults: build 20000 0 9)
# Needs a finished bench/scale/run.sh of FRAMES frames. Runs under `nice -n 10`.
set -euo pipefail
PY="${PYTHON:-/usr/bin/python3}"
BUILD_DIR="${1:-build}"
FRAMES="${2:-20000}"
shift 2 || true
TENTHS=("$@")
[ ${#TENTHS[@]} -gt 0 ] || TENTHS=(0 9)
GLAM="$(realpath "$BUILD_DIR/server/glam")"
HERE="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
WORK="$ROOT/out/bench/scale/$FRAMES"
[ -f "$WORK/samples.tsv" ] && [ -f "$WORK/gt/video.mp4" ] ||
  { echo "no finished scale run in $WORK: run bench/scale/run.sh $BUILD_DIR $FRAMES first" >&2; exit 1; }
fps=$("$PY" -c "import json,sys; print(json.load(open(sys.argv[1]))['fps'])" "$WORK/gt/synth.json")
crf=$("$PY" -c "import json,sys; print(json.load(open(sys.argv[1])).get('crf', 20))" "$WORK/gt/synth.json")
len=$((FRAMES / 10))
OUT="$WORK/segments"
mkdir -p "$OUT"
printf 'tenth\tfirst_frame\tfresh_wall_s\tfresh_cpu_s\n' > "$OUT/fresh.tsv"
for k in "${TENTHS[@]}"; do
  a=$((k * len))
  clip="$OUT/tenth_$k.mp4"
  # Frame-accurate cut (seek, then decode), re-encoded like the synth video.
  ffmpeg -loglevel error -y -ss "$(echo "$a / $fps" | bc -l)" -i "$WORK/gt/video.mp4" -frames:v "$len" \
    -c:v libx264 -crf "$crf" -pix_fmt yuv420p "$clip"
  rm -rf "$OUT/map_$k"
  /usr/bin/time -f "%e %U %S" -o "$OUT/time_$k.txt" nice -n 10 "$GLAM" --log-level warn map "$clip" \
    --intrinsics "$WORK/gt/intrinsics.json" --out "$OUT/map_$k" > "$OUT/map_$k.log" 2>&1
  read -r wall user sys < "$OUT/time_$k.txt"
  printf '%s\t%s\t%s\t%s\n' "$k" "$a" "$wall" "$(echo "$user + $sys" | bc)" >> "$OUT/fresh.tsv"
done
"$PY" - "$WORK" "$len" <<'PYEOF'
import sys
import numpy as np
work, n = sys.argv[1], int(sys.argv[2])
s = np.genfromtxt(f"{work}/samples.tsv", names=True, delimiter="\t")
keep = np.concatenate([[True], np.diff(s["frames_done"]) > 0])
t, d, c = s["t_s"][keep], s["frames_done"][keep], s["cpu_s"][keep]
f = np.atleast_1d(np.genfromtxt(f"{work}/segments/fresh.tsv", names=True, delimiter="\t"))
print("| tenth (frames) | in the run: fps / frames per CPU s | fresh process: fps / frames per CPU s | run / fresh (CPU) |")
print("|---|---|---|---|")
rows = []
for r in f:
    a = int(r["first_frame"])
    wall = np.interp(a + n, d, t) - np.interp(a, d, t)
    cpu = np.interp(a + n, d, c) - np.interp(a, d, c)
    ratio = (n / cpu) / (n / r["fresh_cpu_s"])
    rows.append((a, n / cpu, n / r["fresh_cpu_s"]))
    print(f"| {int(r['tenth'])} ({a}-{a + n}) | {n / wall:.1f} / {n / cpu:.1f} | "
          f"{n / r['fresh_wall_s']:.1f} / {n / r['fresh_cpu_s']:.1f} | {ratio:.2f} |")
if len(rows) >= 2:
    (a0, run0, fresh0), (a1, run1, fresh1) = rows[0], rows[-1]
    total = 1 - run1 / run0
    content = 1 - fresh1 / fresh0
    growth = 1 - (run1 / fresh1) / (run0 / fresh0)
    print(f"\ndecay first -> last listed tenth, frames per CPU second: {100 * total:.1f} % in the run; "
          f"{100 * content:.1f} % between the same frames mapped fresh (content); "
          f"{100 * growth:.1f} % left after dividing out the fresh rates (growth with the flight)")
PYEOF
