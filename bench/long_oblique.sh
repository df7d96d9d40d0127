#!/usr/bin/env bash
# Accuracy and speed of `glam map` on a long oblique flight with yaw turns: a synthetic
# 1280x720 loop (camera 30 degrees from nadir, 15 m relief under 100 m altitude, the loop's
# curvature varies so the heading turns all the time) mapped WITHOUT calibration: the focal
# starts from a guess 10 % too long and is estimated by the submap builder (running median
# of per-keyframe focals). Prints the same metrics as bench/map_speed.sh plus the focal
# estimate and per-submap ATE (each submap Sim3-aligned to ground truth on its own frames).
# Usage: bench/long_oblique.sh [BUILD_DIR] [FRAMES]   (defaults: build, 2000)
# Numbers go to docs/benchmarks.md by hand.
set -euo pipefail
BUILD_DIR="${1:-build}"
FRAMES="${2:-2000}"
GLAM="$BUILD_DIR/server/glam"
WORK="out/bench/long_oblique_${FRAMES}"
mkdir -p "$WORK"

"$GLAM" --log-level warn synth --trajectory loop --frames "$FRAMES" --width 1280 --height 720 \
  --altitude 100 --relief 15 --pitch-deg 30 --seed 6 --out "$WORK/gt"

decode_start=$(date +%s.%N)
ffmpeg -loglevel error -threads 2 -i "$WORK/gt/video.mp4" -f null -
decode_end=$(date +%s.%N)

# Focal guess 10 % too long (the true focal is in the ground truth's intrinsics.json).
TRUE_FOCAL=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['fx'])" "$WORK/gt/intrinsics.json")
GUESS=$(python3 -c "import sys; print(1.1 * float(sys.argv[1]))" "$TRUE_FOCAL")
"$GLAM" --log-level warn map "$WORK/gt/video.mp4" --focal "$GUESS" --out "$WORK/map" > /dev/null
"$GLAM" --log-level warn eval --gt "$WORK/gt" --result "$WORK/map" --json "$WORK/eval.json" > /dev/null

python3 - "$WORK" "$FRAMES" "$decode_start" "$decode_end" "$TRUE_FOCAL" <<'PY'
import glob, json, math, struct, sys
work, frames, d0, d1, true_focal = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
r = json.load(open(f"{work}/map/report.json"))
e = json.load(open(f"{work}/eval.json"))
t = r["timings_s"]

def read_submap_centres(path):
    """Camera centres per frame index from submap.bin (docs/file-formats.md, version 1)."""
    b = open(path, "rb").read()
    assert b[:8] == b"GLAMSUBM" and struct.unpack_from("<I", b, 8)[0] == 1, path
    o = 12 + 4 + 8 + 8
    n = struct.unpack_from("<I", b, o)[0]; o += 4 + n + 8 + 6 * 8
    n = struct.unpack_from("<I", b, o)[0]; o += 4 + n * (8 + 7 * 8 + 8)
    n = struct.unpack_from("<I", b, o)[0]; o += 4
    for _ in range(n):
        o += 4 + 24 + 3 + 128
        k = struct.unpack_from("<I", b, o)[0]; o += 4 + k * 12
    n = struct.unpack_from("<I", b, o)[0]; o += 4
    centres = {}
    for _ in range(n):
        f, _ts, qw, qx, qy, qz, tx, ty, tz = struct.unpack_from("<qd7d", b, o); o += 8 + 8 + 56 + 4
        # centre = -R^T t, R from the unit quaternion (cam_from_submap)
        R = [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
             [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
             [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]
        centres[f] = [-(R[0][i] * tx + R[1][i] * ty + R[2][i] * tz) for i in range(3)]
    return centres

def sim3_rmse(src, dst):
    """RMSE after the least-squares similarity dst ~ s R src + t (Horn's quaternion method)."""
    n = len(src)
    ms = [sum(p[i] for p in src) / n for i in range(3)]
    md = [sum(p[i] for p in dst) / n for i in range(3)]
    a = [[p[i] - ms[i] for i in range(3)] for p in src]
    c = [[p[i] - md[i] for i in range(3)] for p in dst]
    S = [[sum(a[k][i] * c[k][j] for k in range(n)) for j in range(3)] for i in range(3)]
    (xx, xy, xz), (yx, yy, yz), (zx, zy, zz) = S
    N = [[xx + yy + zz, yz - zy, zx - xz, xy - yx],
         [yz - zy, xx - yy - zz, xy + yx, zx + xz],
         [zx - xz, xy + yx, -xx + yy - zz, yz + zy],
         [xy - yx, zx + xz, yz + zy, -xx - yy + zz]]
    # Largest eigenvalue of the symmetric N by shifted power iteration.
    shift = sum(abs(v) for row in N for v in row)
    q = [1.0, 0.1, 0.1, 0.1]
    for _ in range(2000):
        q = [sum(N[i][j] * q[j] for j in range(4)) + shift * q[i] for i in range(4)]
        norm = math.sqrt(sum(v * v for v in q)); q = [v / norm for v in q]
    lam = sum(q[i] * sum(N[i][j] * q[j] for j in range(4)) for i in range(4))
    ssa = sum(v * v for p in a for v in p); ssc = sum(v * v for p in c for v in p)
    s = lam / ssa if ssa > 0 else 0.0
    return math.sqrt(max(ssc - s * lam, 0.0) / n)

gt = {}
fps = e["fps"]
for line in open(f"{work}/gt/gt_trajectory.tum"):
    if line.strip() and not line.startswith("#"):
        v = [float(x) for x in line.split()]
        gt[int(round(v[0] * fps))] = v[1:4]
altitude = json.load(open(f"{work}/gt/synth.json"))["altitude"]
per_submap = []
for path in sorted(glob.glob(f"{work}/map/submaps/*/submap.bin")):
    centres = read_submap_centres(path)
    keys = [f for f in sorted(centres) if f in gt]
    if len(keys) >= 3:
        per_submap.append(sim3_rmse([centres[f] for f in keys], [gt[f] for f in keys]))

print(f"frames {frames} at 1280x720 ({r['processing_size'][0]}x{r['processing_size'][1]} processed), "
      f"oblique loop (30 deg pitch, 100 m altitude, 15 m relief)")
print(f"decode only (ffmpeg, 2 threads): {frames / (d1 - d0):.1f} fps")
print(f"glam map end to end:            {r['processing_fps']:.1f} fps ({t['total']:.1f} s)")
print(f"  decode + SIFT thread busy {t['decode_and_features']:.1f} s, builder {t['builder']:.1f} s "
      f"(bundle adjustment {t['bundle_adjustment']:.1f} s), alignment {t.get('alignment', float('nan')):.2f} s, "
      f"writing {t['writing']:.2f} s")
print(f"  posed {r['frames_posed']}/{r['frames_decoded']} ({100.0 * r['frames_posed'] / max(r['frames_decoded'], 1):.1f} %), "
      f"submaps {r['submaps']} ({r['disconnected_submaps']} disconnected), keyframes {r['keyframes']}, points {r['points']}")
tr, m = e["trajectory"], e.get("map") or {}
print(f"  accuracy: ATE {tr['ate_rmse_m']:.3f} m, scale drift {tr['scale_drift_percent']:.2f} %, "
      f"map median {m.get('median_m', float('nan')):.3f} m")
if per_submap:
    ps = sorted(per_submap)
    print(f"  per-submap ATE (Sim3 per submap): median {ps[len(ps) // 2]:.3f} m, max {ps[-1]:.3f} m "
          f"({100.0 * ps[-1] / altitude:.2f} % of altitude) over {len(ps)} submaps")
f_est = r["focal_original_px"]
print(f"  focal: started {1.1 * true_focal:.1f} px (+10 %), estimated {f_est:.1f} px, "
      f"truth {true_focal:.1f} px ({100.0 * (f_est - true_focal) / true_focal:+.2f} %)")
PY
