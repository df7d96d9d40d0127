#!/usr/bin/env bash
# GLAM vs COLMAP on the same synthetic videos (issue 8's fixed protocol). For each video:
#   GLAM:   every frame, `glam map VIDEO --intrinsics intrinsics.json` (calibrated focal, fixed)
#   COLMAP: every 5th frame (PNGs extracted with ffmpeg, not timed), single PINHOLE camera with
#           the synth intrinsics, focal/principal point NOT refined; SIFT <= 2048 features;
#           sequential matcher, overlap 10 (COLMAP's default quadratic overlap kept); on the loop
#           video also its vocabulary-tree loop detection, with a tree built by
#           `colmap vocab_tree_builder` from the video's own database (no internet to download
#           one; build time listed separately); 2 threads and CPU only everywhere.
# Both results are scored by `glam eval` (COLMAP's model converted by colmap_to_glam.py).
# Writes out/bench/colmap/table.md and the plots docs/images/bench/colmap_*.png.
# Usage: bench/colmap/run.sh [BUILD_DIR] [VIDEOS...]   (videos: lawnmower loop oblique, default all three;
#   also compressed)
#   REUSE_COLMAP=1: re-run GLAM only, scoring against each video's earlier COLMAP result.
# Needs bench/colmap/setup.sh first.
set -euo pipefail
# Debian's python3 (numpy, matplotlib from bench/colmap/setup.sh), not a pyenv/venv one.
PY="${PYTHON:-/usr/bin/python3}"
BUILD_DIR="${1:-build}"
shift || true
VIDEOS=("$@")
[ ${#VIDEOS[@]} -gt 0 ] || VIDEOS=(lawnmower loop oblique)
GLAM="$(realpath "$BUILD_DIR/server/glam")"
HERE="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
OUT="$ROOT/out/bench/colmap"
STRIDE=5
mkdir -p "$OUT"
command -v colmap > /dev/null || { echo "colmap missing: run bench/colmap/setup.sh" >&2; exit 1; }

synth_args() {
  case "$1" in
    lawnmower) echo "--trajectory lawnmower --frames 300 --width 640 --height 360 --altitude 100 --seed 1" ;;
    loop) echo "--trajectory loop --frames 450 --fps 15 --width 640 --height 360 --altitude 40 --seed 4" ;;
    oblique) echo "--trajectory loop --frames 600 --width 640 --height 360 --altitude 60 --pitch-deg 30 --seed 21" ;;
    # Optional (not in the default list): a loop at 100 m compressed like a re-encoded upload
    # (H.264 CRF 24, ~410 kbit/s at 640x360), the compression both tools have to cope with.
    compressed) echo "--trajectory loop --frames 600 --width 640 --height 360 --crf 24 --seed 49" ;;
    *) echo "unknown video $1" >&2; exit 1 ;;
  esac
}

now() { date +%s.%N; }
# cpu FILE CMD...: runs CMD and appends its "user system" CPU seconds to FILE. CPU time is
# reported beside wall time: on a shared machine it is the load-independent measure.
cpu() { local f=$1; shift; /usr/bin/time -f "%U %S" -a -o "$f" "$@"; }
elapsed() { echo "$2 - $1" | bc; }

echo "commit $(git -C "$ROOT" rev-parse --short HEAD), $(nproc) cores, $(colmap help 2>&1 | sed -n 1p)" \
  > "$OUT/machine.txt"
for v in "${VIDEOS[@]}"; do
  W="$OUT/$v"
  mkdir -p "$W"
  # shellcheck disable=SC2046
  "$GLAM" --log-level warn synth $(synth_args "$v") --out "$W/gt"
  fps=$("$PY" -c "import json,sys; print(json.load(open(sys.argv[1]))['fps'])" "$W/gt/synth.json")
  read -r fx fy cx cy < <("$PY" -c "import json,sys; i=json.load(open(sys.argv[1])); print(i['fx'], i['fy'], i['cx'], i['cy'])" "$W/gt/intrinsics.json")
  frames_in=$(wc -l < "$W/gt/gt_trajectory.tum")
  load_before=$(cut -d' ' -f1 /proc/loadavg)

  # ---- GLAM, every frame
  rm -rf "$W/glam"
  t0=$(now)
  rm -f "$W/glam_cpu.txt"
  cpu "$W/glam_cpu.txt" "$GLAM" --log-level warn map "$W/gt/video.mp4" --intrinsics "$W/gt/intrinsics.json" --out "$W/glam" > "$W/glam.log" 2>&1
  t1=$(now)
  echo "$(elapsed "$t0" "$t1")" > "$W/glam_seconds.txt"
  "$GLAM" --log-level warn eval --gt "$W/gt" --result "$W/glam" --json "$W/glam_eval.json" | tee "$W/glam_eval.txt"

  # ---- COLMAP, every 5th frame (REUSE_COLMAP=1: keep this video's earlier COLMAP result)
  if [ "${REUSE_COLMAP:-0}" = 1 ] && [ -f "$W/colmap_times.json" ] && [ -f "$W/colmap_eval.json" ]; then
    echo "$v: reusing the COLMAP result of $(date -r "$W/colmap_times.json" '+%Y-%m-%d %H:%M')"
  else
    rm -f "$W/colmap_cpu.txt" "$W/colmap_vocab_cpu.txt"
    rm -rf "$W/colmap"
    mkdir -p "$W/colmap/images" "$W/colmap/sparse"
    ffmpeg -loglevel error -i "$W/gt/video.mp4" -vf "select=not(mod(n\,$STRIDE))" -vsync vfr \
      -start_number 0 "$W/colmap/images/tmp_%06d.png"
    for f in "$W"/colmap/images/tmp_*.png; do
      k=$(basename "$f" .png); k=$((10#${k#tmp_}))
      mv "$f" "$W/colmap/images/$(printf '%06d' $((k * STRIDE))).png"
    done
    frames_used=$(ls "$W/colmap/images" | wc -l)
    DB="$W/colmap/database.db"
    t0=$(now)
    cpu "$W/colmap_cpu.txt" colmap feature_extractor --database_path "$DB" --image_path "$W/colmap/images" \
      --ImageReader.single_camera 1 --ImageReader.camera_model PINHOLE \
      --ImageReader.camera_params "$fx,$fy,$cx,$cy" \
      --SiftExtraction.max_num_features 2048 --SiftExtraction.num_threads 2 \
      --SiftExtraction.use_gpu 0 > "$W/colmap/extract.log" 2>&1
    t1=$(now)
    extract_s=$(elapsed "$t0" "$t1")
    loop_args=()
    vocab_s=0
    if [ "$v" = loop ]; then
      cpu "$W/colmap_vocab_cpu.txt" colmap vocab_tree_builder --database_path "$DB" --vocab_tree_path "$W/colmap/vocab_tree.bin" \
        --num_visual_words 4096 --branching 64 > "$W/colmap/vocab.log" 2>&1
      t1b=$(now)
      vocab_s=$(elapsed "$t1" "$t1b")
      t1=$t1b
      loop_args=(--SequentialMatching.loop_detection 1
                 --SequentialMatching.vocab_tree_path "$W/colmap/vocab_tree.bin")
    fi
    cpu "$W/colmap_cpu.txt" colmap sequential_matcher --database_path "$DB" --SequentialMatching.overlap 10 \
      --SiftMatching.num_threads 2 --SiftMatching.use_gpu 0 "${loop_args[@]}" > "$W/colmap/match.log" 2>&1
    t2=$(now)
    cpu "$W/colmap_cpu.txt" colmap mapper --database_path "$DB" --image_path "$W/colmap/images" --output_path "$W/colmap/sparse" \
      --Mapper.num_threads 2 --Mapper.ba_refine_focal_length 0 --Mapper.ba_refine_principal_point 0 \
      --Mapper.ba_refine_extra_params 0 > "$W/colmap/mapper.log" 2>&1
    t3=$(now)
    load_after=$(cut -d' ' -f1 /proc/loadavg)
    # The largest model (COLMAP may split a sequence into several).
    best=""; best_n=-1; models=0
    for m in "$W"/colmap/sparse/*/; do
      models=$((models + 1))
      mkdir -p "${m%/}_txt"
      colmap model_converter --input_path "$m" --output_path "${m%/}_txt" --output_type TXT > /dev/null
      n=$(grep -v '^#' "${m%/}_txt/images.txt" | grep -c . || true); n=$((n / 2))
      if [ "$n" -gt "$best_n" ]; then best="${m%/}_txt"; best_n=$n; fi
    done
    "$PY" "$HERE/colmap_to_glam.py" "$best" "$W/colmap/result" "$fps" > /dev/null
    "$GLAM" --log-level warn eval --gt "$W/gt" --result "$W/colmap/result" --fps "$fps" \
      --json "$W/colmap_eval.json" | tee "$W/colmap_eval.txt"
    cat > "$W/colmap_times.json" <<JSON
  {"extract_s": $extract_s, "vocab_s": $vocab_s,
   "match_s": $(elapsed "$t1" "$t2"), "map_s": $(elapsed "$t2" "$t3"), "models": $models,
   "registered": $best_n, "frames_in": $frames_in, "frames_used": $frames_used,
   "load_before": $load_before, "load_after": $load_after}
JSON
  fi
done
"$PY" "$HERE/table.py" "$OUT" "$ROOT/docs/images/bench" "${VIDEOS[@]}" | tee "$OUT/table.md"
