#!/usr/bin/python3
"""Summarises a scale run of bench/scale/run.sh: peak RSS, fps in the first and last tenth of
the frames, submaps, graph size, alignment latency, and an extrapolation to 100,000 frames
(RSS: linear in the baseline; throughput: by cost component, thread 2's growth); draws
fps, RSS and alignment latency over the run. Works on a partial run too
(samples only; report.json is written at the end).
Usage: summarize.py WORK_DIR PLOT_PNG [TARGET_FRAMES=100000]"""
import json
import os
import sys

import numpy as np


def stage_labels(tids, mains, names):
    """Stage of each thread: the engine names its threads (engine/core/thread_name.h) and the
    main thread runs the builder. A thread inherits its creator's name, so "glam" also covers
    ffmpeg's decoding threads and Ceres' workers started by the main thread, and "glam-decode"
    OpenCV's parallel_for_ workers (created on the decoder thread's first OpenCV call)."""
    labels = {}
    for tid, main, name in zip(tids, mains, names):
        labels[tid] = "builder (main thread)" if main else f"{name} threads"
    return labels


SHORT_LIVED = "short-lived threads (not sampled)"


def stage_series(work, t, cpu):
    """Cumulative CPU seconds by stage against frames done, from threads.tsv: (frames, {stage:
    array}) or None. A thread's CPU time counts from its last sample on after it exits;
    threads that live shorter than the sampling interval (the per-window SIFT helpers) are
    never sampled and show up as the rest of the process's CPU time."""
    path = os.path.join(work, "threads.tsv")
    if cpu is None or not os.path.exists(path):
        return None
    rows = np.genfromtxt(path, names=True, delimiter="\t", dtype=None, encoding=None)
    if rows.size == 0:
        return None
    labels = stage_labels(list(rows["tid"]), list(rows["is_main"]), list(rows["name"]))
    stages = sorted(set(labels.values()))
    last = {}
    by_time = {}
    for r in rows:
        by_time.setdefault(round(float(r["t_s"]), 1), []).append(r)
    series = {k: [] for k in stages + [SHORT_LIVED]}
    proc_t = {round(float(x), 1): c for x, c in zip(t, cpu)}
    frames = []
    for when in sorted(by_time):
        for r in by_time[when]:
            last[int(r["tid"])] = float(r["cpu_s"])
        if when not in proc_t:
            continue
        sums = {k: 0.0 for k in stages}
        for tid, c in last.items():
            sums[labels[tid]] += c
        for k in stages:
            series[k].append(sums[k])
        series[SHORT_LIVED].append(proc_t[when] - sum(sums.values()))
        frames.append(max(int(r["frames_done"]) for r in by_time[when]))
    frames = np.array(frames, float)
    keep = np.concatenate([[True], np.diff(frames) > 0])
    if keep.sum() < 4:
        return None
    return frames[keep], {k: np.array(v)[keep] for k, v in series.items()}


def print_stage_cpu(stages, n, tenth):
    """CPU ms per frame by stage in the first and the last tenth."""
    f, series = stages
    a0 = f[0]
    print(f"CPU ms per frame by stage, first tenth (frames {a0:.0f}-{tenth:.0f}) -> last tenth "
          f"({n - tenth:.0f}-{n}):")
    for k, v in series.items():
        first = (np.interp(tenth, f, v) - np.interp(a0, f, v)) / (tenth - a0) * 1000
        last_t = (np.interp(n, f, v) - np.interp(n - tenth, f, v)) / tenth * 1000
        print(f"  {k}: {first:.1f} -> {last_t:.1f} ms ({100 * (last_t / first - 1) if first > 0 else 0:+.0f} %)")


def plot_stage_cpu(ax, stages, n):
    """CPU ms per frame by stage over the run, stacked, in windows of a twentieth of the run.
    The SIFT helpers caught alive by a sample and those that were not are one band."""
    f, series = stages
    merged = {}
    for k, v in series.items():
        key = "SIFT helpers" if k in ("glam-sift threads", SHORT_LIVED) else k
        merged[key] = merged.get(key, 0) + v
    edges = np.linspace(f[0], n, 21)
    mid = 0.5 * (edges[1:] + edges[:-1])
    bands = [(np.diff(np.interp(edges, f, v)) / np.diff(edges) * 1000, k) for k, v in merged.items()]
    ax.stackplot(mid, *[b for b, _ in bands], labels=[k for _, k in bands], alpha=0.8)
    ax.set_ylabel("CPU ms per frame")
    ax.set_xlabel("frames done")
    ax.set_ylim(0, 1.45 * sum(b for b, _ in bands).max())  # room for the legend above
    ax.legend(fontsize=7, loc="upper left", ncol=3)
    ax.grid(alpha=0.3)


def main():
    work, png = sys.argv[1], sys.argv[2]
    target = int(sys.argv[3]) if len(sys.argv) > 3 else 100000
    s = np.genfromtxt(os.path.join(work, "samples.tsv"), names=True, delimiter="\t")
    t, rss, done = s["t_s"], s["rss_mb"], s["frames_done"]
    rep_path = os.path.join(work, "map", "report.json")
    rep = json.load(open(rep_path)) if os.path.exists(rep_path) else None
    total = rep["frames_decoded"] if rep else int(done.max())
    finished = rep is not None
    print(open(os.path.join(work, "machine.txt")).read().strip())
    print(f"run {'finished' if finished else 'PARTIAL (still running or stopped)'}: "
          f"{int(done.max())} frames done after {t.max():.0f} s")
    print(f"peak RSS (sampled every {np.median(np.diff(t)):.0f} s): {rss.max():.0f} MB")

    # Time at which a frame count was reached (progress is monotone; interpolate).
    keep = np.concatenate([[True], np.diff(done) > 0])
    tt, dd = t[keep], done[keep]

    def time_at(frames):
        return float(np.interp(frames, dd, tt))

    n = int(done.max())
    # The tenths end at the last sample taken while frames were still streaming: the frame count
    # reaches the total only after the end of input, when the final submap's completion and the
    # export have run, which are no part of the flight's steady state.
    streaming = dd[dd < total]
    if finished and len(streaming) >= 2 and streaming.max() >= 0.9 * total:
        n = int(streaming.max())
    tenth = n / 10
    fps_first = tenth / (time_at(tenth) - time_at(0 if dd[0] == 0 else dd[0]))
    fps_last = tenth / (time_at(n) - time_at(n - tenth))
    print(f"fps in the first tenth (frames 0-{tenth:.0f}): {fps_first:.2f}; last tenth "
          f"(frames {n - tenth:.0f}-{n}): {fps_last:.2f}; decay {100 * (1 - fps_last / fps_first):.1f} %")
    cpu = s["cpu_s"][keep] if "cpu_s" in s.dtype.names else None
    stages = None
    if cpu is not None:
        def cpu_at(frames):
            return float(np.interp(frames, dd, cpu))
        cfirst = tenth / (cpu_at(tenth) - cpu_at(dd[0]))
        clast = tenth / (cpu_at(n) - cpu_at(n - tenth))
        print(f"frames per CPU second (load-independent): first tenth {cfirst:.2f}, last tenth "
              f"{clast:.2f}; decay {100 * (1 - clast / cfirst):.1f} %; {cpu.max():.0f} CPU s in all")
        stages = stage_series(work, s["t_s"], s["cpu_s"])
        if stages is not None:
            print_stage_cpu(stages, n, tenth)
    if os.path.exists(os.path.join(work, "map_time.txt")):
        wall = float(open(os.path.join(work, "map_time.txt")).read().split()[1])
        print(f"wall time {wall:.0f} s = {int(done.max()) / wall:.2f} fps overall")

    # Trends: RSS grows while a submap is open (its frames' features are kept until the
    # submap completes; bounded by max_frames_per_submap) and drops back when it completes, so
    # only the baseline after each completion extrapolates. That needs several completed
    # submaps; a shorter run prints why it skips the extrapolation.
    sub = s["submaps"]
    completed = int(sub.max())
    if completed >= 5:
        base_f, base_r = [], []
        for k in range(1, completed + 1):
            m = sub == k
            if m.any():
                i = np.argmin(np.where(m, rss, np.inf))
                base_f.append(done[i])
                base_r.append(rss[i])
        slope, icpt = np.polyfit(base_f, base_r, 1)
        excursion = float((rss - (icpt + slope * done)).max())
        print(f"RSS baseline after submap completions grows {slope * 1000:.1f} MB per 1000 frames; "
              f"open-submap excursion up to {excursion:.0f} MB -> ~{icpt + slope * target + excursion:.0f} MB "
              f"peak at {target} frames (linear extrapolation of the baseline)")
    else:
        print(f"only {completed} submap(s) completed during sampling: too short for a trend, "
              "no extrapolation")
    win = max(5, len(tt) // 40)
    fps_w = (dd[win:] - dd[:-win]) / (tt[win:] - tt[:-win])
    mid = 0.5 * (dd[win:] + dd[:-win])

    lat = None
    if rep:
        g = rep.get("graph", {})
        a = rep.get("alignment", {})
        print(f"frames decoded {rep['frames_decoded']}, posed {rep['frames_posed']}, submaps "
              f"{rep['submaps']}, keyframes {rep['keyframes']}, points {rep['points']}")
        print(f"graph: {g.get('edges')} edges ({g.get('retrieved_edges')} retrieved), "
              f"{g.get('landmarks')} landmarks")
        per = a.get("per_submap", [])
        if per:
            lat = np.array([[p["submap"], p["total_s"], p.get("optimization_s", 0)] for p in per])
            k = max(1, len(lat) // 10)
            print(f"alignment latency: mean {a.get('mean_latency_s', 0):.2f} s, max "
                  f"{a.get('max_latency_s', 0):.2f} s; mean of the first tenth of submaps "
                  f"{lat[:k, 1].mean():.2f} s, last tenth {lat[-k:, 1].mean():.2f} s "
                  f"(optimisation {lat[:k, 2].mean():.2f} s -> {lat[-k:, 2].mean():.2f} s)")
            if cpu is not None and len(lat) >= 5:
                # Extrapolation by cost component: thread 1's state is bounded by the open
                # submap, so its CPU per frame does not grow with the flight; what grows is
                # thread 2's work per submap (retrieval, verification, graph solves). Its wall
                # time per submap (an upper bound of its CPU time) is fitted linearly over the
                # submap index and extrapolated. The fit uses the second half of the submaps:
                # the first few have fewer earlier submaps to retrieve and verify, a ramp that
                # a fit over all of them would extend to 100,000 frames. The first/last-tenth
                # rates above also vary with content (terrain texture), which this does not
                # predict.
                align_total = float(lat[:, 1].sum())
                cpu_total = float(cpu.max())
                thread1 = (cpu_total - align_total) / n
                per_submap_frames = n / len(lat)
                steady = lat[len(lat) // 2:] if len(lat) >= 10 else lat
                slope_a, icpt_a = np.polyfit(steady[:, 0], steady[:, 1], 1)
                target_submaps = target / per_submap_frames
                # Never below today's cost: a falling fit is noise, not a speed-up to come.
                end_cost = max(steady[:, 1].mean(), icpt_a + slope_a * target_submaps)
                rate_end = 1.0 / (thread1 + lat[-k:, 1].mean() / per_submap_frames)
                rate_target = 1.0 / (thread1 + end_cost / per_submap_frames)
                print(f"by cost component: thread 2 took {align_total:.0f} of {cpu_total:.0f} CPU s "
                      f"({100 * align_total / cpu_total:.1f} %); thread 1 + decoding {thread1 * 1000:.1f} ms "
                      f"CPU per frame (does not grow with the flight); alignment per submap grows "
                      f"{slope_a:.3f} s per submap over the second half of the submaps -> "
                      f"{end_cost:.2f} s at {target} frames "
                      f"({target_submaps:.0f} submaps): {rate_target:.2f} frames per CPU s there vs "
                      f"{rate_end:.2f} at the end of this run ({100 * (1 - rate_target / rate_end):.1f} % "
                      "further decay from thread 2's growth)"
                      + ("" if len(lat) >= 10 else "; fewer than 10 submaps: the fit includes the "
                         "first submaps' ramp and overstates the growth"))
        graph_path = os.path.join(work, "map", "graph.json")
        if os.path.exists(graph_path):
            gj = json.load(open(graph_path))
            print(f"graph.json: {len(gj['nodes'])} nodes, {len(gj['edges'])} edges, "
                  f"{gj.get('graph_landmarks')} landmark nodes, "
                  f"{sum(1 for x in gj['nodes'] if x.get('disconnected'))} disconnected, "
                  f"{os.path.getsize(graph_path) / 1e6:.1f} MB")
    ev = os.path.join(work, "eval.json")
    if os.path.exists(ev):
        e = json.load(open(ev))
        tr, mp = e["trajectory"], e.get("map") or {}
        print(f"accuracy: fraction posed {tr['fraction_posed']:.3f}, ATE {tr['ate_rmse_m']:.2f} m, "
              f"scale drift {tr['scale_drift_percent']:.2f} %, map median {mp.get('median_m', float('nan')):.2f} m")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = 2 + (lat is not None) + (stages is not None)
    fig, axes = plt.subplots(rows, 1, figsize=(6.5, 2.3 * rows), dpi=80)
    axes[0].plot(mid, fps_w, "C0-", label="frames per wall second")
    if cpu is not None:
        cps = (dd[win:] - dd[:-win]) / np.maximum(cpu[win:] - cpu[:-win], 1e-6)
        axes[0].plot(mid, cps, "C1-", label="frames per CPU second")
    axes[0].legend(fontsize=8)
    axes[0].set_ylabel("throughput")
    axes[0].set_xlabel("frames done")
    axes[0].set_title(f"scale run: {int(done.max())} frames, 640x360" + ("" if finished else " (partial)"))
    axes[0].grid(alpha=0.3)
    axes[1].plot(done, rss, "C3-")
    for k in range(1, completed + 1):
        m = np.nonzero(sub >= k)[0]
        if len(m):
            axes[1].axvline(done[m[0]], color="0.6", lw=0.8, ls=":")
    axes[1].set_ylabel("RSS (MB); : submap done")
    axes[1].set_xlabel("frames done")
    axes[1].grid(alpha=0.3)
    if lat is not None:
        axes[2].plot(lat[:, 0], lat[:, 1], "C2.", ms=3, label="total")
        axes[2].plot(lat[:, 0], lat[:, 2], "C1.", ms=3, label="optimisation")
        axes[2].set_ylabel("alignment (s)")
        axes[2].set_xlabel("submap")
        axes[2].legend(fontsize=8)
        axes[2].grid(alpha=0.3)
    if stages is not None:
        plot_stage_cpu(axes[-1], stages, n)
    fig.tight_layout()
    fig.savefig(png)


if __name__ == "__main__":
    main()
