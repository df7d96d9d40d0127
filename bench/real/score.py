#!/usr/bin/python3
"""Scores camera centres against GPS for bench/real/run.sh: registered images, horizontal
(east/north) error after a 3D Sim3 (Umeyama) fit to the GPS positions, run time; draws the
top view. Result trajectories use t = image index, gps_enu.tum uses t = index / 2 fps.
Usage: score.py OUT_DIR GPS_TUM PLOT_PNG NAME=SECONDS..."""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "colmap"))
from benchlib import umeyama  # noqa: E402

RESULTS = {"glam_intrinsics": ("GLAM, EXIF focal as intrinsics, 2000 features", "glam_intrinsics/trajectory.tum"),
           "glam_no_intrinsics": ("GLAM, no intrinsics, 2000 features", "glam_no_intrinsics/trajectory.tum"),
           "glam_intrinsics_8000": ("GLAM, EXIF focal, 8000 features (folder default)",
                                    "glam_intrinsics_8000/trajectory.tum"),
           "glam_refine_8000": ("GLAM, EXIF focal refined (--refine-focal), 8000 features",
                                "glam_refine_8000/trajectory.tum"),
           "colmap": ("COLMAP (exhaustive)", "colmap/result/trajectory.tum")}


def read_indexed(path, fps):
    out = {}
    if not os.path.exists(path):
        return out
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        f = line.split()
        out[int(round(float(f[0]) * fps))] = np.array(list(map(float, f[1:4])))
    return out


def main():
    out, gps_path, png = sys.argv[1:4]
    seconds = dict(a.split("=") for a in sys.argv[4:])
    gps = read_indexed(gps_path, 2.0)
    print(open(os.path.join(out, "machine.txt")).read().strip() + "\n")
    print("| run | registered | horizontal RMSE after Sim3 (m) | max (m) | run time |")
    print("|---|---|---|---|---|")
    tracks = {}
    for key, (label, rel) in RESULTS.items():
        est = read_indexed(os.path.join(out, rel), 1.0)
        idx = sorted(i for i in est if i in gps)
        rmse = mx = float("nan")
        if len(idx) >= 3:
            a = np.array([est[i] for i in idx])
            b = np.array([gps[i] for i in idx])
            s, r, t = umeyama(a, b)
            al = (s * (r @ a.T)).T + t
            h = np.linalg.norm(al[:, :2] - b[:, :2], axis=1)
            rmse, mx = float(np.sqrt((h ** 2).mean())), float(h.max())
            tracks[label] = (idx, al)
        extra = ""
        rep = os.path.join(out, os.path.dirname(rel), "report.json")
        if key.startswith("glam") and os.path.exists(rep):
            r = json.load(open(rep))
            extra = (f" (submaps {r.get('submaps')}, focal {r.get('focal_px', float('nan')):.0f} px)"
                     if isinstance(r.get("focal_px"), (int, float)) else f" (submaps {r.get('submaps')})")
        print(f"| {label}{extra} | {len(idx)} / {len(gps)} | {rmse:.2f} | {mx:.2f} "
              f"| {float(seconds.get(key, 'nan')):.1f} s |")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 5), dpi=80)
    g = np.array([gps[i] for i in sorted(gps)])
    ax.plot(g[:, 0], g[:, 1], "k-o", ms=4, lw=2, alpha=0.3, label="GPS")
    for (label, (idx, al)), style in zip(tracks.items(), ("C0x-", "C2+-", "C1^-", "C4v-", "C3.-")):
        ax.plot(al[:, 0], al[:, 1], style, ms=6, lw=1, label=f"{label} ({len(idx)} images)")
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title("Brighton Beach: camera centres after Sim3")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1))
    fig.tight_layout()
    fig.savefig(png, bbox_inches="tight")


if __name__ == "__main__":
    main()
