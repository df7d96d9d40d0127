#!/usr/bin/env bash
# GLAM's COLMAP export (colmap/ of a result, docs/file-formats.md) read by COLMAP itself: for
# a calibrated pinhole flight and an uncalibrated one through a barrel lens (k1 estimated,
# written as an OPENCV camera), `glam map`, then `colmap model_analyzer` on colmap/ (COLMAP's
# own projection of every track: its mean reprojection error must match GLAM's map) and
# `colmap image_undistorter` on the frames extracted at full size by the ffmpeg command the docs
# give (the image names must resolve). A third flight, 1280x720, is mapped at 640x360
# (--max-image-size 640): its model must still describe the full-size frames (COLMAP does not
# check an image's size against its camera, so the script compares the camera with the video).
# Prints one line per flight. Not a test: COLMAP is a benchmark
# dependency (bench/colmap/setup.sh), never a test one.
# Usage: bench/colmap/export_check.sh [BUILD_DIR]
set -euo pipefail
BUILD_DIR="${1:-build}"
GLAM="$(realpath "$BUILD_DIR/server/glam")"
command -v colmap > /dev/null || { echo "colmap missing: run bench/colmap/setup.sh" >&2; exit 1; }
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
OUT="$ROOT/out/bench/colmap_export"
rm -rf "$OUT"
mkdir -p "$OUT"

check() {
  local name=$1 synth_args=$2 map_args=$3 extra_map_args=${4:-}
  local w="$OUT/$name"
  mkdir -p "$w"
  # shellcheck disable=SC2086
  "$GLAM" --log-level warn synth $synth_args --out "$w/gt"
  local intrinsics=""
  [ "$map_args" = calibrated ] && intrinsics="--intrinsics $w/gt/intrinsics.json"
  # shellcheck disable=SC2086
  "$GLAM" --log-level warn map "$w/gt/video.mp4" $intrinsics $extra_map_args --out "$w/result" > "$w/map.log" 2>&1
  read -r model width height _ < <(grep -v '^#' "$w/result/colmap/cameras.txt" | head -1 | cut -d' ' -f2-)
  local video_size
  video_size=$(ffprobe -v error -select_streams v:0 -show_entries stream=width,height -of csv=s=x:p=0 "$w/gt/video.mp4")
  if [ "${width}x${height}" != "$video_size" ]; then
    echo "$name: cameras.txt is ${width}x${height}, the video ${video_size}" >&2
    exit 1
  fi
  mkdir -p "$w/images"
  ffmpeg -loglevel error -i "$w/gt/video.mp4" -fps_mode passthrough -start_number 0 -q:v 2 "$w/images/frame_%06d.jpg"
  colmap model_analyzer --path "$w/result/colmap" > "$w/analyzer.txt" 2>&1
  colmap image_undistorter --image_path "$w/images" --input_path "$w/result/colmap" --output_path "$w/dense" \
    > "$w/undistorter.txt" 2>&1
  local images points error undistorted
  images=$(sed -n 's/.*Registered images: //p' "$w/analyzer.txt")
  points=$(sed -n 's/.*Points: //p' "$w/analyzer.txt")
  error=$(sed -n 's/.*Mean reprojection error: //p' "$w/analyzer.txt")
  undistorted=$(find "$w/dense/images" -name '*.jpg' | wc -l)
  printf "%-22s camera %-8s %sx%s images %4s  points %6s  COLMAP mean reprojection error %-10s undistorted images %s\n" \
    "$name" "$model" "$width" "$height" "$images" "$points" "$error" "$undistorted"
}

check loop_calibrated \
  "--trajectory loop --frames 450 --fps 15 --width 640 --height 360 --altitude 40 --seed 4" calibrated
check barrel_lens_estimated \
  "--trajectory lawnmower --frames 300 --width 640 --height 360 --altitude 100 --seed 6 --k1 -0.12" estimated
check hd_mapped_at_half_size \
  "--trajectory lawnmower --frames 300 --width 1280 --height 720 --altitude 100 --seed 1" calibrated "--max-image-size 640"
