#!/usr/bin/env bash
# Submap size against loop length (docs/benchmarks.md, "Submap size and short loops").
#
# Smaller submaps bend less: on a flight that is one short loop, each submap's own drift (a few
# tenths of a degree) is what sets the trajectory error, and the drifts of two long submaps
# nearly cancel around the loop, so no loop edge can correct them (docs/benchmarks.md).
# This renders the oblique benchmark flight (one 600-frame loop at 60 m, 30 degrees from nadir,
# as in bench/colmap/run.sh) with several seeds and maps each one, calibrated, at several
# submap sizes (keyframes per submap). Prints one row per run:
# submaps, graph edges (retrieved = loop closures), posed frames, ATE after Sim3 and the map's
# median point error (`glam eval`).
#
# Usage: bench/submap_size.sh [BUILD_DIR]   (default build; outputs in out/bench/submap_size)
#   SEEDS="21 22 23 24 25" SIZES="20 16 12" (the defaults) choose the clips and submap sizes;
#   MAP_ARGS are passed to every `glam map`.
# Takes ~9 minutes on 2 cores with the defaults (15 runs of 600 frames at 640x360 + renders).
set -euo pipefail
BUILD_DIR="${1:-build}"
GLAM="$BUILD_DIR/server/glam"
WORK="out/bench/submap_size"
SEEDS="${SEEDS:-21 22 23 24 25}"
SIZES="${SIZES:-20 16 12}"
mkdir -p "$WORK"

printf "| seed | keyframes per submap | submaps | edges (retrieved) | posed | ATE | map median |\n|---|---|---|---|---|---|---|\n"
for seed in $SEEDS; do
  gt="$WORK/seed$seed/gt"
  [ -f "$gt/video.mp4" ] || "$GLAM" --log-level warn synth --trajectory loop --frames 600 --width 640 --height 360 \
    --altitude 60 --pitch-deg 30 --seed "$seed" --out "$gt" > /dev/null
  for size in $SIZES; do
    out="$WORK/seed$seed/map_kf$size"
    # shellcheck disable=SC2086  # MAP_ARGS are words
    "$GLAM" --log-level warn map "$gt/video.mp4" --intrinsics "$gt/intrinsics.json" --keyframes-per-submap "$size" \
      ${MAP_ARGS:-} --out "$out" > "$out.log" 2>&1 || { tail -5 "$out.log"; exit 1; }
    "$GLAM" --log-level warn eval --gt "$gt" --result "$out" --json "$out/eval.json" > /dev/null
    python3 - "$out" "$seed" "$size" <<'PY'
import json, sys
out, seed, size = sys.argv[1:4]
r = json.load(open(f"{out}/report.json"))
e = json.load(open(f"{out}/eval.json"))
g = r["graph"]
print(f"| {seed} | {size} | {r['submaps']} | {g['edges']} ({g['retrieved_edges']}) | "
      f"{100 * e['trajectory']['fraction_posed']:.1f} % | {e['trajectory']['ate_rmse_m']:.3f} m | "
      f"{e['map']['median_m']:.3f} m |")
PY
  done
done
