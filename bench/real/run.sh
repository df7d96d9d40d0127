#!/usr/bin/env bash
# Real drone photos (Brighton Beach sample: 18 DJI images, 1280x720, ~13.5 m apart, 40 m
# above ground; GPS positions in gps_enu.tum as ground truth) through `glam map` (with the EXIF
# focal guess as calibrated intrinsics, and without intrinsics) and through COLMAP (exhaustive
# matcher, SIFT <= 2048 features, 2 threads, CPU, one SIMPLE_RADIAL camera initialised with
# the EXIF focal guess and refined). Reports registered images, horizontal error of the camera
# centres against GPS after a Sim3 fit (3D Umeyama on all registered centres) and run time.
# Writes out/bench/real/table.md and docs/images/bench/real_topview.png.
# GLAM runs four ways: EXIF focal as fixed intrinsics with 2000 SIFT features (the video
# default), no intrinsics (focal estimated) with 2000, and intrinsics with 8000 features (the
# default of `glam map` for image folders since this benchmark showed the difference), and the
# last with `--refine-focal`: the EXIF focal is a guess, and COLMAP refines its own start too.
# Usage: bench/real/run.sh [BUILD_DIR] [DATA_DIR]   (REUSE_COLMAP=1: keep an earlier COLMAP result)
#   (defaults: build, data/brighton_beach, the copy in this project; needs bench/colmap/setup.sh)
set -euo pipefail
# Debian's python3 (numpy, matplotlib from bench/colmap/setup.sh), not a pyenv/venv one.
PY="${PYTHON:-/usr/bin/python3}"
BUILD_DIR="${1:-build}"
HERE="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
DATA="$(realpath "${2:-$ROOT/data/brighton_beach}")"
GLAM="$(realpath "$BUILD_DIR/server/glam")"
OUT="$ROOT/out/bench/real"
mkdir -p "$OUT"
now() { date +%s.%N; }
elapsed() { echo "$2 - $1" | bc; }

echo "commit $(git -C "$ROOT" rev-parse --short HEAD), $(nproc) cores, data $DATA" > "$OUT/machine.txt"
# intrinsics_guess.json -> GLAM's intrinsics.json (pinhole, no distortion known).
"$PY" - "$DATA/intrinsics_guess.json" "$OUT/intrinsics.json" <<'PY'
import json, sys
g = json.load(open(sys.argv[1]))
json.dump({"model": "pinhole", "width": int(g["width"]), "height": int(g["height"]), "fx": g["fx"],
           "fy": g["fy"], "cx": g["cx"], "cy": g["cy"]}, open(sys.argv[2], "w"), indent=1)
PY

declare -A SECONDS_OF
for variant in glam_intrinsics glam_no_intrinsics glam_intrinsics_8000 glam_refine_8000; do
  rm -rf "${OUT:?}/$variant"
  case "$variant" in
    glam_intrinsics) args=(--intrinsics "$OUT/intrinsics.json" --max-features 2000) ;;
    glam_no_intrinsics) args=(--max-features 2000) ;;
    glam_intrinsics_8000) args=(--intrinsics "$OUT/intrinsics.json" --max-features 8000) ;;
    glam_refine_8000) args=(--intrinsics "$OUT/intrinsics.json" --max-features 8000 --refine-focal) ;;
  esac
  t0=$(now)
  "$GLAM" --log-level info map "$DATA/images" "${args[@]}" --out "$OUT/$variant" > "$OUT/$variant.log" 2>&1 || \
    echo "glam map $variant failed (exit $?), see $OUT/$variant.log"
  SECONDS_OF[$variant]=$(elapsed "$t0" "$(now)")
done

if [ "${REUSE_COLMAP:-0}" = 1 ] && [ -f "$OUT/colmap/seconds.txt" ]; then
  SECONDS_OF[colmap]=$(cat "$OUT/colmap/seconds.txt")
else
rm -rf "$OUT/colmap"
mkdir -p "$OUT/colmap/sparse"
DB="$OUT/colmap/database.db"
fx=$("$PY" -c "import json,sys; print(json.load(open(sys.argv[1]))['fx'])" "$OUT/intrinsics.json")
t0=$(now)
colmap feature_extractor --database_path "$DB" --image_path "$DATA/images" \
  --ImageReader.single_camera 1 --ImageReader.camera_model SIMPLE_RADIAL \
  --ImageReader.camera_params "$fx,640,360,0" --SiftExtraction.max_num_features 2048 \
  --SiftExtraction.num_threads 2 --SiftExtraction.use_gpu 0 > "$OUT/colmap/extract.log" 2>&1
colmap exhaustive_matcher --database_path "$DB" --SiftMatching.num_threads 2 \
  --SiftMatching.use_gpu 0 > "$OUT/colmap/match.log" 2>&1
colmap mapper --database_path "$DB" --image_path "$DATA/images" --output_path "$OUT/colmap/sparse" \
  --Mapper.num_threads 2 > "$OUT/colmap/mapper.log" 2>&1
SECONDS_OF[colmap]=$(elapsed "$t0" "$(now)")
echo "${SECONDS_OF[colmap]}" > "$OUT/colmap/seconds.txt"
best=""; best_n=-1
for m in "$OUT"/colmap/sparse/*/; do
  mkdir -p "${m%/}_txt"
  colmap model_converter --input_path "$m" --output_path "${m%/}_txt" --output_type TXT > /dev/null
  n=$(( $(grep -v '^#' "${m%/}_txt/images.txt" | grep -c . || true) / 2 ))
  if [ "$n" -gt "$best_n" ]; then best="${m%/}_txt"; best_n=$n; fi
done
# Image names are the frame index; the converter's t = index / 1 matches GLAM's image-folder
# timestamps (t = index).
[ -n "$best" ] && "$PY" "$ROOT/bench/colmap/colmap_to_glam.py" "$best" "$OUT/colmap/result" 1 > /dev/null
fi

"$PY" "$HERE/score.py" "$OUT" "$DATA/gps_enu.tum" "$ROOT/docs/images/bench/real_topview.png" \
  "glam_intrinsics=${SECONDS_OF[glam_intrinsics]}" "glam_no_intrinsics=${SECONDS_OF[glam_no_intrinsics]}" \
  "glam_intrinsics_8000=${SECONDS_OF[glam_intrinsics_8000]}" \
  "glam_refine_8000=${SECONDS_OF[glam_refine_8000]}" "colmap=${SECONDS_OF[colmap]}" | tee "$OUT/table.md"
