#!/usr/bin/env bash
# The demo behind `make run`: renders a short synthetic drone flight with exact ground truth,
# maps it with `glam map`, and evaluates the result against the ground truth with `glam eval`.
# Outputs go to out/demo/ (clip in gt/, map in map/). Re-running skips the render.
set -euo pipefail
BUILD_DIR="${1:-build}"
GLAM="$BUILD_DIR/server/glam"
OUT="out/demo"
mkdir -p "$OUT"

echo "== 1/3 rendering a synthetic 300-frame lawnmower flight (640x360, 100 m altitude)"
"$GLAM" synth --trajectory lawnmower --frames 300 --width 640 --height 360 --altitude 100 \
  --seed 1 --out "$OUT/gt"

echo "== 2/3 mapping it: glam map $OUT/gt/video.mp4 --out $OUT/map"
"$GLAM" map "$OUT/gt/video.mp4" --intrinsics "$OUT/gt/intrinsics.json" \
  --keyframes-per-submap 6 --out "$OUT/map"

echo "== 3/3 evaluating against the ground truth"
"$GLAM" eval --gt "$OUT/gt" --result "$OUT/map" --json "$OUT/eval.json"
echo "Map: $OUT/map (trajectory.tum, points.ply, report.json, graph.json); metrics: $OUT/eval.json"
