"""Small helpers shared by the benchmark scripts under bench/: TUM trajectories and a
Sim3 (Umeyama) alignment of camera centres, used for the plots and for the real-data
benchmark (whose GPS ground truth is not a `glam synth` directory, so `glam eval` cannot
score it). The numbers in the COLMAP table come from `glam eval`, not from here."""
import numpy as np


def read_tum(path):
    """Returns {timestamp: (centre (3,), quaternion xyzw)} from a TUM file."""
    out = {}
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        f = line.split()
        out[round(float(f[0]), 4)] = (np.array(list(map(float, f[1:4]))),
                                       np.array(list(map(float, f[4:8]))))
    return out


def umeyama(src, dst, with_scale=True):
    """s, R, t minimising sum |dst - (s R src + t)|^2 (Umeyama 1991). src, dst: (N, 3)."""
    mu_s, mu_d = src.mean(0), dst.mean(0)
    xs, xd = src - mu_s, dst - mu_d
    cov = xd.T @ xs / len(src)
    u, d, vt = np.linalg.svd(cov)
    sign = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[2, 2] = -1
    r = u @ sign @ vt
    var_s = (xs ** 2).sum() / len(src)
    s = np.trace(np.diag(d) @ sign) / var_s if with_scale else 1.0
    t = mu_d - s * r @ mu_s
    return s, r, t


def aligned_centres(result_tum, gt_tum):
    """Matched timestamps, aligned estimated centres and true centres (after Sim3)."""
    est, gt = read_tum(result_tum), read_tum(gt_tum)
    ts = sorted(t for t in est if t in gt)
    a = np.array([est[t][0] for t in ts])
    b = np.array([gt[t][0] for t in ts])
    s, r, t = umeyama(a, b)
    return np.array(ts), (s * (r @ a.T)).T + t, b
