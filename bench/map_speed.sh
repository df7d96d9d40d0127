#!/usr/bin/env bash
# End-to-end speed of `glam map` on a synthetic 1280x720 clip, with the decode-only rate of
# the same video beside it (the physical limit) and the time per stage from report.json.
# Usage: bench/map_speed.sh [BUILD_DIR] [FRAMES]   (defaults: build, 300)
# Prints one block per mode; numbers go to docs/benchmarks.md by hand.
set -euo pipefail
BUILD_DIR="${1:-build}"
FRAMES="${2:-300}"
GLAM="$BUILD_DIR/server/glam"
WORK="out/bench/map_speed_${FRAMES}"
mkdir -p "$WORK"

"$GLAM" --log-level warn synth --trajectory lawnmower --frames "$FRAMES" --width 1280 --height 720 \
  --altitude 100 --seed 3 --out "$WORK/gt"

decode_start=$(date +%s.%N)
ffmpeg -loglevel error -threads 2 -i "$WORK/gt/video.mp4" -f null -
decode_end=$(date +%s.%N)

# Default schedule (SIFT every 6th frame at 30 fps, KLT in between) and the paper's (SIFT on
# every frame); MODES="default paper" (the default) or one of them.
for mode in ${MODES:-default paper}; do
  case "$mode" in
    default) flags=() ;;
    paper) flags=(--detect-every 1) ;;
    *) echo "unknown mode $mode"; exit 2 ;;
  esac
  "$GLAM" --log-level warn map "$WORK/gt/video.mp4" --intrinsics "$WORK/gt/intrinsics.json" \
    --out "$WORK/map_$mode" "${flags[@]}" > /dev/null
  "$GLAM" --log-level warn eval --gt "$WORK/gt" --result "$WORK/map_$mode" --json "$WORK/eval_$mode.json" > /dev/null

  python3 - "$WORK" "$FRAMES" "$decode_start" "$decode_end" "$mode" <<'PY'
import json, sys
work, frames, d0, d1, mode = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
r = json.load(open(f"{work}/map_{mode}/report.json"))
e = json.load(open(f"{work}/eval_{mode}.json"))
t = r["timings_s"]
print(f"== {mode}: SIFT on every {r['detection_interval']}. frame ({r['frames_detected']} of {r['frames_decoded']} detected)")
print(f"frames {frames} at 1280x720 ({r['processing_size'][0]}x{r['processing_size'][1]} processed)")
print(f"decode only (ffmpeg, 2 threads): {frames / (d1 - d0):.1f} fps")
print(f"glam map end to end:            {r['processing_fps']:.1f} fps ({t['total']:.1f} s)")
print(f"  decode + features thread busy {t['decode_and_features']:.1f} s, builder {t['builder']:.1f} s "
      f"(bundle adjustment {t['bundle_adjustment']:.1f} s), alignment {t['alignment']:.2f} s, writing {t['writing']:.2f} s")
print(f"  tiles (Draco + quantized GLB per submap): {t['tiles']:.3f} s for {r['submaps']} submaps "
      f"({1000 * t['tiles'] / max(1, r['submaps']):.0f} ms each), {r['points']} points")
print(f"  posed {r['frames_posed']}/{r['frames_decoded']}, submaps {r['submaps']}, keyframes {r['keyframes']}, points {r['points']}")
tr, m = e["trajectory"], e.get("map") or {}
print(f"  accuracy: ATE {tr['ate_rmse_m']:.3f} m, scale drift {tr['scale_drift_percent']:.2f} %, "
      f"map median {m.get('median_m', float('nan')):.3f} m")
PY
done
