#!/usr/bin/python3
"""Prints the GLAM vs COLMAP table (markdown) from the files bench/colmap/run.sh leaves in
out/bench/colmap/<video>/ and draws the top view of
both trajectories against ground truth and their position error over time, per video.
Usage: table.py OUT_DIR PLOT_DIR VIDEO..."""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from benchlib import aligned_centres  # noqa: E402


def load(path):
    return json.load(open(path))


def cpu_seconds(path):
    """Sum of the "user system" lines /usr/bin/time appended (0 when absent)."""
    if not os.path.exists(path):
        return 0.0
    return sum(float(x) for line in open(path) for x in line.split())


def main():
    out, plot_dir, videos = sys.argv[1], sys.argv[2], sys.argv[3:]
    print(open(os.path.join(out, "machine.txt")).read().strip() + "\n")
    print("| video | tool | frames (input / used) | posed | wall time | fps (input / wall) "
          "| CPU time | ATE (m) | map median error (m) | points |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    notes = []
    for v in videos:
        w = os.path.join(out, v)
        g_eval, c_eval = load(f"{w}/glam_eval.json"), load(f"{w}/colmap_eval.json")
        g_rep = load(f"{w}/glam/report.json")
        g_s = float(open(f"{w}/glam_seconds.txt").read())
        ct = load(f"{w}/colmap_times.json")
        c_s = ct["extract_s"] + ct["match_s"] + ct["map_s"]
        n = ct["frames_in"]
        g_cpu, c_cpu = cpu_seconds(f"{w}/glam_cpu.txt"), cpu_seconds(f"{w}/colmap_cpu.txt")
        for tool, ev, secs, cpu, used, posed, pts in (
                ("GLAM", g_eval, g_s, g_cpu, n, g_rep["frames_posed"], g_rep["points"]),
                ("COLMAP", c_eval, c_s, c_cpu, ct["frames_used"], ct["registered"],
                 c_eval["map"]["points"] if c_eval.get("map") else 0)):
            tr, mp = ev["trajectory"], ev.get("map") or {}
            print(f"| {v} | {tool} | {n} / {used} | {posed} | {secs:.1f} s | {n / secs:.2f} "
                  f"| {cpu:.0f} s | {tr['ate_rmse_m']:.3f} | {mp.get('median_m', float('nan')):.3f} | {pts} |")
        ratio = c_s / g_s
        cpu_ratio = c_cpu / g_cpu if g_cpu > 0 else float("nan")
        ate_ratio = g_eval["trajectory"]["ate_rmse_m"] / c_eval["trajectory"]["ate_rmse_m"]
        vocab_cpu = cpu_seconds(f"{w}/colmap_vocab_cpu.txt")
        notes.append(f"* {v}: GLAM {ratio:.1f}x faster than COLMAP in wall time, {cpu_ratio:.1f}x in "
                     f"CPU time (COLMAP: extraction "
                     f"{ct['extract_s']:.1f} s, matching {ct['match_s']:.1f} s, mapping "
                     f"{ct['map_s']:.1f} s" + (f", vocabulary tree build {ct['vocab_s']:.1f} s "
                                                 f"/ {vocab_cpu:.0f} CPU s not included"
                                                 if ct["vocab_s"] else "")
                     + f"; {ct['models']} model(s)); GLAM ATE = {ate_ratio:.3g}x COLMAP's; "
                     f"load average {ct['load_before']} before / {ct['load_after']} after")
    print()
    print("\n".join(notes))
    for v in videos:
        plot(out, plot_dir, v)


def plot(out, plot_dir, v):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    w = os.path.join(out, v)
    gt = f"{w}/gt/gt_trajectory.tum"
    runs = {"GLAM (every frame)": f"{w}/glam/trajectory.tum",
            "COLMAP (every 5th frame)": f"{w}/colmap/result/trajectory.tum"}
    os.makedirs(plot_dir, exist_ok=True)
    fig, ax = plt.subplots(figsize=(5.5, 5), dpi=80)
    truth = np.loadtxt(gt, comments="#")
    ax.plot(truth[:, 1], truth[:, 2], "k-", lw=3, alpha=0.3, label="ground truth")
    aligned = {}
    for (label, path), style in zip(runs.items(), ("C0-", "C3.")):
        ts, est, ref = aligned_centres(path, gt)
        aligned[label] = (ts, np.linalg.norm(est - ref, axis=1))
        ax.plot(est[:, 0], est[:, 1], style, ms=3, lw=1, label=label)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(f"{v} video: camera centres after Sim3 (top view)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{plot_dir}/colmap_{v}_topview.png")
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(6.5, 3), dpi=80)
    for (label, (ts, err)), style in zip(aligned.items(), ("C0-", "C3.-")):
        ax.plot(ts, err, style, ms=3, lw=1, label=label)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{v} video: camera centre error after Sim3")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(f"{plot_dir}/colmap_{v}_error.png")
    plt.close(fig)


if __name__ == "__main__":
    main()
