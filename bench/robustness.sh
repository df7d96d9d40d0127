#!/usr/bin/env bash
# Robustness over flights and cameras the tests do not use (docs/benchmarks.md, "Robustness
# over flights and cameras").
#
# Renders twenty-four synthetic 600-frame clips at 640x360 with `glam synth` (skipped when
# already rendered; seeds 41-52, 54-59, 66, 67, 81, 83-85, used by no test), each changing one
# thing from the lawnmower at 100 m: speed, altitude, lens, distortion, trajectory, terrain,
# compression, pitch, frame rate, a take-off climb, the horizon in view (75 and 80 deg from
# nadir, turning), content that moves on its own (open water with drifting ripples that renew
# themselves: lakes, and a coast where the first seconds are mostly water; the same coast with
# ripples that only drift, like foam on a current; drifting cloud shadows at 100 and 40 m);
# and derives five more from the lawnmower clip with ffmpeg filters (an on-screen display,
# exposure flicker, defocus, motion blur, a 3 s freeze of the stream). Maps each one as a user
# without a calibration would (`glam map`, no intrinsics: the
# focal is estimated from the 0.8 x long-side guess) and, with CALIBRATED=1, also with the
# clip's true intrinsics. Prints one row per run: estimated focal against the truth, whether
# it was held (docs/algorithm.md, focal length), submaps, posed frames, ATE after Sim3 and the
# map's median error (`glam eval`), and the run's wall time.
#
# Usage: bench/robustness.sh [BUILD_DIR]   (default build; outputs in out/bench/robustness)
# Variants: GLAM_MAP_ARGS="--detect-every 9" adds options to every `glam map`, and
# RUN_TAG=name keeps that variant's outputs apart (out/bench/robustness/CLIP/uncalibrated-name);
# RUNS=calibrated maps with the true intrinsics only; ONLY="clip ..." runs those clips only.
# Takes ~12 minutes per kind of run on 2 cores (~25 with CALIBRATED=1), plus ~25 minutes of
# rendering the first time.
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
  [barrel_mild]="--trajectory lawnmower --k1 -0.07 --seed 54"
  [pincushion]="--trajectory loop --k1 0.06 --seed 55"
  [orbit_barrel]="--trajectory orbit --pitch-deg 40 --altitude 50 --k1 -0.1 --seed 56"
  [high_barrel]="--trajectory lawnmower --altitude 200 --speed 15 --k1 -0.1 --seed 57"
  [wide_barrel]="--trajectory loop --focal 320 --k1 -0.05 --seed 58"
  [orbit]="--trajectory orbit --pitch-deg 40 --altitude 50 --seed 47"
  [flat]="--trajectory lawnmower --relief 0 --building-density 0 --seed 48"
  [crf32]="--trajectory loop --crf 32 --seed 49"
  [pitch60]="--trajectory loop --pitch-deg 60 --altitude 40 --seed 50"
  [high]="--trajectory lawnmower --altitude 200 --speed 15 --seed 51"
  [fps24]="--trajectory loop --fps 24 --wobble-deg 4 --seed 52"
  [climb]="--trajectory lawnmower --climb-from 30 --seed 59"
  [horizon]="--trajectory lawnmower --pitch-deg 75 --altitude 60 --seed 66"
  [horizon_loop]="--trajectory loop --pitch-deg 80 --altitude 40 --seed 67"
  [lakes]="--trajectory lawnmower --water 0.3 --seed 84"
  [coast]="--trajectory lawnmower --water 0.3 --seed 85"
  [coast_current]="--trajectory lawnmower --water 0.3 --water-renewal 0 --seed 85"
  [clouds]="--trajectory lawnmower --cloud-shadows 0.4 --seed 81"
  [clouds_low]="--trajectory loop --altitude 40 --cloud-shadows 0.4 --seed 83"
)
ORDER="lawnmower fast low wide_lens narrow_lens distorted barrel_mild pincushion orbit_barrel high_barrel wide_barrel orbit flat crf32 pitch60 high fps24 climb horizon horizon_loop lakes coast coast_current clouds clouds_low"
# Derived from the lawnmower clip by an ffmpeg filter (Debian's ffmpeg, re-encoded at CRF 16);
# the ground truth is copied, and where the filter changes what a frame shows, adjusted.
declare -A DERIVED=(
  [osd]="ffmpeg: static on-screen display (text box with a running clock, frame marker)"
  [flicker]="ffmpeg: brightness +-0.12 and contrast +-20 % oscillating (eq)"
  [defocus]="ffmpeg: Gaussian blur sigma 2 px (gblur)"
  [motion_blur]="ffmpeg: each frame the mean of three (tmix; ~3.7 px smear)"
  [freeze]="ffmpeg: frames 201-290 repeat frame 200, then a 30 m jump (freezeframes)"
)
DERIVED_ORDER="osd flicker defocus motion_blur freeze"

printf "| clip | synth arguments (or derivation) | run | focal (truth) | held | k1 (truth) | submaps | posed | ATE | map median | wall time |\n"
printf "|---|---|---|---|---|---|---|---|---|---|---|\n"
# derive NAME: WORK/NAME/gt from WORK/lawnmower/gt through DERIVED[NAME] (skipped when done).
derive() {
  local name=$1 src="$WORK/lawnmower/gt" dst="$WORK/$1/gt"
  # shellcheck disable=SC2086  # the clip's arguments are words
  [ -f "$src/video.mp4" ] || "$GLAM" --log-level warn synth $BASE ${CLIP[lawnmower]} --out "$src" > /dev/null
  [ -f "$dst/video.mp4" ] && [ "$dst/video.mp4" -nt "$src/video.mp4" ] && return 0
  mkdir -p "$dst"
  cp "$src"/*.json "$src"/*.f32 "$dst"/
  local filter
  case "$name" in
    osd) filter=(-vf "drawbox=x=10:y=10:w=200:h=40:color=black@0.6:t=fill,drawtext=text='REC %{pts\\:hms}  ALT 100m':x=15:y=20:fontsize=16:fontcolor=white,drawbox=x=540:y=300:w=90:h=50:color=white@0.8:t=3") ;;
    flicker) filter=(-vf "eq=brightness='0.12*sin(2*t)':contrast='1+0.2*sin(1.3*t)':eval=frame") ;;
    defocus) filter=(-vf "gblur=sigma=2") ;;
    motion_blur) filter=(-vf "tmix=frames=3") ;;
    freeze) filter=(-filter_complex "[0:v]split[a][b];[a][b]freezeframes=first=200:last=290:replace=200") ;;
  esac
  ffmpeg -v error -y -i "$src/video.mp4" "${filter[@]}" -c:v libx264 -crf 16 -pix_fmt yuv420p "$dst/video.mp4"
  python3 - "$src/gt_trajectory.tum" "$dst/gt_trajectory.tum" "$name" <<'PY'
import sys
src, dst, name = sys.argv[1:4]
lines = open(src).read().splitlines()
header = [l for l in lines if l.startswith("#")]
poses = [l.split() for l in lines if l.strip() and not l.startswith("#")]
out = []
for k, p in enumerate(poses):
    if name == "motion_blur":  # frame k averages frames k-2..k: it shows frame k-1's view
        shown = poses[max(k - 1, 0)]
    elif name == "freeze" and 200 < k <= 290:  # frames 201-290 repeat frame 200
        shown = poses[200]
    else:
        shown = p
    out.append(" ".join([p[0]] + shown[1:]))
open(dst, "w").write("\n".join(header + out) + "\n")
PY
}

for name in ${ONLY:-$ORDER $DERIVED_ORDER}; do
  if [ -z "${CLIP[$name]:-}" ] && [ -z "${DERIVED[$name]:-}" ]; then
    echo "robustness.sh: unknown clip '$name' (clips: $ORDER $DERIVED_ORDER)" >&2
    exit 2
  fi
  if [ -n "${CLIP[$name]:-}" ]; then
    # shellcheck disable=SC2086  # the clip's arguments are words
    "$GLAM" --log-level warn synth $BASE ${CLIP[$name]} --out "$WORK/$name/gt" > /dev/null
  else
    derive "$name"
  fi
  runs="uncalibrated"
  [ "${CALIBRATED:-0}" = 1 ] && runs="$runs calibrated"
  runs="${RUNS:-$runs}"
  for run in $runs; do
    args=()
    [ "$run" = calibrated ] && args=(--intrinsics "$WORK/$name/gt/intrinsics.json")
    # shellcheck disable=SC2206  # the variant's options are words
    args+=(${GLAM_MAP_ARGS:-})
    out="$WORK/$name/$run${RUN_TAG:+-$RUN_TAG}"
    start=$(date +%s.%N)
    "$GLAM" --log-level warn map "$WORK/$name/gt/video.mp4" "${args[@]}" --out "$out" > "$out.log" 2>&1 \
      || { tail -5 "$out.log"; exit 1; }
    seconds=$(echo "$(date +%s.%N) - $start" | bc)
    "$GLAM" --log-level warn eval --gt "$WORK/$name/gt" --result "$out" --json "$out/eval.json" > /dev/null
    how="${CLIP[$name]:-${DERIVED[$name]:-}}"
    python3 - "$out" "$WORK/$name/gt" "$name" "$run" "$how" "$seconds" <<'PY'
import json, sys
out, gt, name, run, synth, seconds = sys.argv[1:7]
intrinsics = json.load(open(f"{gt}/intrinsics.json"))
truth = intrinsics["fx"]
r = json.load(open(f"{out}/report.json"))
e = json.load(open(f"{out}/eval.json"))
f = r["focal_px"]
m = e.get("map") or {}
median = f"{m['median_m']:.2f} m" if "median_m" in m else "-"
print(f"| {name} | `{synth}` | {run} | {f:.0f} ({truth:.0f}, {100 * (f / truth - 1):+.1f} %) | "
      f"{'yes' if r.get('focal_held') else 'no'} | "
      f"{r.get('k1', 0):+.3f}{' held' if r.get('k1_held') else ''} ({intrinsics.get('k1', 0):+.2f}) | {r['submaps']} | "
      f"{100 * e['trajectory']['fraction_posed']:.0f} % | {e['trajectory']['ate_rmse_m']:.3f} m | {median} | {float(seconds):.1f} s |")
PY
  done
done
