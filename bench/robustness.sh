#!/usr/bin/env bash
# Robustness over flights and cameras the tests do not use (docs/benchmarks.md, "Robustness
# over flights and cameras").
#
# Renders twelve synthetic 600-frame clips at 640x360 with `glam synth` (skipped when already
# rendered; seeds 41-52, used by no test), each changing one thing from the lawnmower at
# 100 m: speed, altitude, lens, distortion, trajectory, terrain, compression, pitch, frame
# rate. Maps each one as a user without a calibration would (`glam map`, no intrinsics: the
# focal is estimated from the 0.8 x long-side guess) and, with CALIBRATED=1, also with the
# clip's true intrinsics. Prints one row per run: estimated focal against the truth, whether
# it was held (docs/algorithm.md, focal length), submaps, posed frames, ATE after Sim3 and the
# map's median error (`glam eval`).
#
# Usage: bench/robustness.sh [BUILD_DIR]   (default build; outputs in out/bench/robustness)
# Takes ~5 minutes on 2 cores (~10 with CALIBRATED=1).
set -euo pipefail
BUILD_DIR="${1:-build}"
GLAM="$BUILD_DIR/server/glam"
WORK="out/bench/robustness"
mkdir -p "$WORK"

BASE="--width 640 --height 360 --frames 600"
declare -A CLIP=(
  [lawnmower]="--trajectory lawnmower --seed 41"
  [fast]="--trajectory lawnmower --speed 20 --altitude 50 --seed 42"
  [low]="--trajectory lawnmower --altitude 25 --speed 8 --seed 43"
  [wide_lens]="--trajectory loop --focal 320 --seed 44"
  [narrow_lens]="--trajectory lawnmower --focal 900 --altitude 80 --seed 45"
  [distorted]="--trajectory lawnmower --k1 -0.15 --k2 0.02 --seed 46"
  [orbit]="--trajectory orbit --pitch-deg 40 --altitude 50 --seed 47"
  [flat]="--trajectory lawnmower --relief 0 --building-density 0 --seed 48"
  [crf32]="--trajectory loop --crf 32 --seed 49"
  [pitch60]="--trajectory loop --pitch-deg 60 --altitude 40 --seed 50"
  [high]="--trajectory lawnmower --altitude 200 --speed 15 --seed 51"
  [fps24]="--trajectory loop --fps 24 --wobble-deg 4 --seed 52"
)
ORDER="lawnmower fast low wide_lens narrow_lens distorted orbit flat crf32 pitch60 high fps24"

printf "| clip | synth arguments | run | focal (truth) | held | submaps | posed | ATE | map median |\n"
printf "|---|---|---|---|---|---|---|---|---|\n"
for name in $ORDER; do
  # shellcheck disable=SC2086  # the clip's arguments are words
  "$GLAM" --log-level warn synth $BASE ${CLIP[$name]} --out "$WORK/$name/gt" > /dev/null
  runs="uncalibrated"
  [ "${CALIBRATED:-0}" = 1 ] && runs="$runs calibrated"
  for run in $runs; do
    args=()
    [ "$run" = calibrated ] && args=(--intrinsics "$WORK/$name/gt/intrinsics.json")
    out="$WORK/$name/$run"
    "$GLAM" --log-level warn map "$WORK/$name/gt/video.mp4" "${args[@]}" --out "$out" > "$out.log" 2>&1 \
      || { tail -5 "$out.log"; exit 1; }
    "$GLAM" --log-level warn eval --gt "$WORK/$name/gt" --result "$out" --json "$out/eval.json" > /dev/null
    python3 - "$out" "$WORK/$name/gt" "$name" "$run" "${CLIP[$name]}" <<'PY'
import json, sys
out, gt, name, run, synth = sys.argv[1:6]
truth = json.load(open(f"{gt}/intrinsics.json"))["fx"]
r = json.load(open(f"{out}/report.json"))
e = json.load(open(f"{out}/eval.json"))
f = r["focal_px"]
m = e.get("map") or {}
median = f"{m['median_m']:.2f} m" if "median_m" in m else "-"
print(f"| {name} | `{synth}` | {run} | {f:.0f} ({truth:.0f}, {100 * (f / truth - 1):+.1f} %) | "
      f"{'yes' if r.get('focal_held') else 'no'} | {r['submaps']} | "
      f"{100 * e['trajectory']['fraction_posed']:.0f} % | {e['trajectory']['ate_rmse_m']:.3f} m | {median} |")
PY
  done
done
