#!/usr/bin/python3
"""Converts a COLMAP text model (cameras.txt, images.txt, points3D.txt from
`colmap model_converter --output_type TXT`) into GLAM's result files so that `glam eval`
scores COLMAP and GLAM with the same code (docs/file-formats.md):

  trajectory.tum  t tx ty tz qx qy qz qw  = world_from_cam (COLMAP stores cam_from_world),
                  t = frame index / fps, the frame index being the image name's number
  points.ply      binary little-endian, float x y z + uchar red green blue

Usage: colmap_to_glam.py MODEL_TXT_DIR OUT_DIR FPS
Prints the number of registered images and points.
"""
import os
import re
import struct
import sys

import numpy as np


def quat_to_rot(qw, qx, qy, qz):
    n = np.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    qw, qx, qy, qz = qw / n, qx / n, qy / n, qz / n
    return np.array([
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ])


def read_images(path):
    """Returns [(frame_index, centre (3,), world_from_cam quaternion (qx, qy, qz, qw))]."""
    lines = [l for l in open(path) if l.strip() and not l.startswith("#")]
    out = []
    # images.txt alternates a pose line and a line of 2D observations.
    for pose_line in lines[0::2]:
        f = pose_line.split()
        qw, qx, qy, qz = map(float, f[1:5])
        t = np.array(list(map(float, f[5:8])))
        name = f[9]
        frame = int(re.findall(r"\d+", os.path.basename(name))[-1])
        r_cw = quat_to_rot(qw, qx, qy, qz)
        centre = -r_cw.T @ t
        # world_from_cam rotation = R_cw^T: the conjugate quaternion.
        out.append((frame, centre, (-qx, -qy, -qz, qw)))
    out.sort(key=lambda x: x[0])
    return out


def read_points(path):
    pts = []
    for l in open(path):
        if l.startswith("#") or not l.strip():
            continue
        f = l.split()
        pts.append((float(f[1]), float(f[2]), float(f[3]), int(f[4]), int(f[5]), int(f[6])))
    return pts


def write_ply(path, pts):
    with open(path, "wb") as fh:
        fh.write((
            "ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(pts)}\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
        ).encode())
        for x, y, z, r, g, b in pts:
            fh.write(struct.pack("<fffBBB", x, y, z, r, g, b))


def main():
    model, out, fps = sys.argv[1], sys.argv[2], float(sys.argv[3])
    os.makedirs(out, exist_ok=True)
    images = read_images(os.path.join(model, "images.txt"))
    with open(os.path.join(out, "trajectory.tum"), "w") as fh:
        for frame, c, q in images:
            fh.write(f"{frame / fps:.6f} {c[0]:.6f} {c[1]:.6f} {c[2]:.6f} "
                     f"{q[0]:.9f} {q[1]:.9f} {q[2]:.9f} {q[3]:.9f}\n")
    pts = read_points(os.path.join(model, "points3D.txt"))
    write_ply(os.path.join(out, "points.ply"), pts)
    print(f"{len(images)} {len(pts)}")


if __name__ == "__main__":
    main()
