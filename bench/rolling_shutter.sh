#!/usr/bin/env bash
# Rolling shutter (docs/benchmarks.md, "Rolling shutter"; docs/algorithm.md).
#
# Renders synthetic 600-frame 640x360 clips whose rows are exposed one after the other (`glam
# synth --rolling-shutter-ms`, ground truth = the middle row's pose), plus the lawnmower flight
# with a global shutter, and maps each calibrated (`--intrinsics`) three ways: the shutter taken
# as global (`--rolling-shutter-ms 0`), the readout given, and the readout estimated (`auto`,
# the default). The lawnmower clips are also mapped uncalibrated (focal and k1 estimated).
# Prints one row per run: readout used (estimated: the value found), focal against the truth,
# ATE after Sim3 and the map's median error (`glam eval`), wall time.
#
# Usage: bench/rolling_shutter.sh [BUILD_DIR]   (default build; outputs in out/bench/rolling_shutter)
# Takes ~6 minutes on 2 cores (rendering ~3 of them, skipped when the clips exist).
set -euo pipefail
BUILD_DIR="${1:-build}"
GLAM="$BUILD_DIR/server/glam"
WORK="out/bench/rolling_shutter"
mkdir -p "$WORK"

BASE="--width 640 --height 360 --frames 600"
declare -A CLIP=(
  [lawnmower_global]="--trajectory lawnmower --seed 41"
  [lawnmower]="--trajectory lawnmower --seed 41 --rolling-shutter-ms 30"
  [fast]="--trajectory lawnmower --speed 20 --altitude 50 --seed 42 --rolling-shutter-ms 30"
  [orbit]="--trajectory orbit --pitch-deg 40 --altitude 50 --seed 47 --rolling-shutter-ms 30"
  [loop24]="--trajectory loop --fps 24 --wobble-deg 4 --seed 52 --rolling-shutter-ms 40"
)
ORDER="lawnmower_global lawnmower fast orbit loop24"

printf "| clip | synth arguments | camera | shutter taken as | readout used | focal (truth) | ATE | map median | wall time |\n"
printf "|---|---|---|---|---|---|---|---|---|\n"
for name in $ORDER; do
  # shellcheck disable=SC2086  # the clip's arguments are words
  "$GLAM" --log-level warn synth $BASE ${CLIP[$name]} --out "$WORK/$name/gt" > /dev/null
  truth=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1])).get('rolling_shutter_ms', 0))" "$WORK/$name/gt/synth.json")
  runs="calibrated:0 calibrated:given calibrated:auto"
  case "$name" in lawnmower*) runs="$runs uncalibrated:0 uncalibrated:given uncalibrated:auto" ;; esac
  for run in $runs; do
    camera="${run%%:*}"
    mode="${run##*:}"
    readout="$mode"
    [ "$mode" = given ] && readout="$truth"
    [ "$name" = lawnmower_global ] && [ "$mode" = given ] && continue  # given = 0 there
    args=(--rolling-shutter-ms "$readout")
    [ "$camera" = calibrated ] && args+=(--intrinsics "$WORK/$name/gt/intrinsics.json")
    out="$WORK/$name/$camera-$mode"
    start=$(date +%s.%N)
    "$GLAM" --log-level warn map "$WORK/$name/gt/video.mp4" "${args[@]}" --out "$out" > "$out.log" 2>&1 \
      || { tail -5 "$out.log"; exit 1; }
    seconds=$(echo "$(date +%s.%N) - $start" | bc)
    "$GLAM" --log-level warn eval --gt "$WORK/$name/gt" --result "$out" --json "$out/eval.json" > /dev/null
    python3 - "$out" "$WORK/$name/gt" "$name" "${CLIP[$name]}" "$camera" "$mode" "$truth" "$seconds" <<'PY'
import json, sys
out, gt, name, synth, camera, mode, truth, seconds = sys.argv[1:9]
truth_focal = json.load(open(f"{gt}/intrinsics.json"))["fx"]
r = json.load(open(f"{out}/report.json"))
e = json.load(open(f"{out}/eval.json"))
rs = r["rolling_shutter"]
taken = {"0": "global", "given": f"{float(truth):g} ms (the truth)", "auto": "estimated"}[mode]
used = f"{rs['readout_ms']:.1f} ms"
if rs.get("estimated"):
    if not rs.get("determined"):
        used += " (undetermined)"
    elif rs.get("decided_at_submap", 0) > 0:
        used += f" (from submap {rs['decided_at_submap']})"
f = r["focal_px"]
m = e.get("map") or {}
median = f"{m['median_m']:.2f} m" if "median_m" in m else "-"
print(f"| {name} | `{synth}` | {camera} | {taken} | {used} | {f:.0f} ({truth_focal:.0f}, {100 * (f / truth_focal - 1):+.1f} %) | "
      f"{e['trajectory']['ate_rmse_m']:.3f} m | {median} | {float(seconds):.1f} s |")
PY
  done
done
