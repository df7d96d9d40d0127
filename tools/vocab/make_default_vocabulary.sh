#!/usr/bin/env bash
# Reproduces data/vocabulary/glam_default.vocab, the vocabulary tree embedded in GLAM (see
# data/vocabulary/README.md). Usage:
#
#   tools/vocab/make_default_vocabulary.sh GLAM_BIN BRIGHTON_IMAGES_DIR [WORK_DIR] [OUT]
#
#   GLAM_BIN              the `glam` executable (e.g. build/server/glam)
#   BRIGHTON_IMAGES_DIR   the 18 DJI images of the Brighton Beach sample (BSD-2-Clause,
#                         https://github.com/pierotofy/drone_dataset_brighton_beach), 1280x720
#   WORK_DIR              where the synthetic training clips are rendered (default: a temp dir)
#   OUT                   output file (default: data/vocabulary/glam_default.vocab)
#
# Training imagery = those 18 real images + 6 synthetic clips rendered with seeds 9001..9006
# (tests use seeds 1..10), varied altitude, camera pitch, relief and building density, 40 frames
# each at 2 fps (frames ~5 m apart or more). Every frame is one training document. Deterministic:
# same inputs, same seed, same file (up to floating-point differences between machines).
set -euo pipefail

GLAM=${1:?GLAM_BIN}
BRIGHTON=${2:?BRIGHTON_IMAGES_DIR}
WORK=${3:-$(mktemp -d)}
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${4:-$HERE/../../data/vocabulary/glam_default.vocab}
mkdir -p "$WORK"

render() {  # name, then glam synth options
  local name=$1
  shift
  "$GLAM" --log-level warn synth --width 1280 --height 720 --fps 2 --frames 40 --out "$WORK/$name" "$@"
}
render s9001 --seed 9001 --trajectory lawnmower --altitude 80 --pitch-deg 0 --relief 12
render s9002 --seed 9002 --trajectory loop --altitude 120 --pitch-deg 20 --relief 25
render s9003 --seed 9003 --trajectory orbit --altitude 60 --pitch-deg 35 --relief 6 --building-density 2
render s9004 --seed 9004 --trajectory lawnmower --altitude 150 --pitch-deg 10 --relief 40 --building-density 0.3
render s9005 --seed 9005 --trajectory loop --altitude 45 --pitch-deg 0 --relief 8 --building-density 1.5
render s9006 --seed 9006 --trajectory lawnmower --altitude 100 --pitch-deg 45 --relief 20

"$GLAM" vocab train --out "$OUT" --branching 10 --depth 4 --iterations 10 --seed 1 \
  --max-descriptors 400000 --frames-per-input 40 \
  --description "GLAM default vocabulary v1: Brighton Beach DJI sample (18 images, BSD-2-Clause, (c) 2017 Piero Toffanin) + glam synth seeds 9001-9006; tools/vocab/make_default_vocabulary.sh" \
  "$BRIGHTON" "$WORK"/s9001/video.mp4 "$WORK"/s9002/video.mp4 "$WORK"/s9003/video.mp4 \
  "$WORK"/s9004/video.mp4 "$WORK"/s9005/video.mp4 "$WORK"/s9006/video.mp4
"$GLAM" vocab info "$OUT"
