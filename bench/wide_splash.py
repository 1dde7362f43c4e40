#!/usr/bin/python3
"""Writes a wide, shallow splash of about N particles as a binary PLY point cloud: a pool
16 : 4 : 1 (x long) on a lattice of spacing d with 10 % jitter holding 80 % of the particles, and
droplets of 1-30 particles over it up to four pool depths high (as tests/support's wide_splash).

    wide_splash.py N OUT.ply [d]
"""
import sys

import numpy as np


def wide_splash(count, d=0.01, seed=7):
    rng = np.random.default_rng(seed)
    depth = max(2, round((count * 0.8 / 64) ** (1 / 3)))
    i, j, k = np.meshgrid(np.arange(16 * depth), np.arange(4 * depth), np.arange(depth), indexing="ij")
    pool = np.stack([i, j, k], -1).reshape(-1, 3) * d + rng.uniform(-0.1 * d, 0.1 * d, (i.size, 3))
    parts = [pool]
    left = count - len(pool)
    top = (depth - 1) * d
    offsets = np.stack(np.meshgrid(*[np.arange(-2, 3)] * 3, indexing="ij"), -1).reshape(-1, 3)
    offsets = offsets[np.argsort((offsets ** 2).sum(1), kind="stable")] * d  # nearest the centre first
    while left > 0:
        m = min(int(rng.integers(1, 31)), left)
        c = rng.uniform([2 * d, 2 * d, top + 3 * d], [(16 * depth - 3) * d, (4 * depth - 3) * d, top + 4 * depth * d])
        parts.append(c + offsets[:m] + rng.normal(0, 0.05 * d, (m, 3)))
        left -= m
    return np.concatenate(parts).astype("<f4")


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    count, out = int(sys.argv[1]), sys.argv[2]
    d = float(sys.argv[3]) if len(sys.argv) > 3 else 0.01
    points = wide_splash(count, d)
    with open(out, "wb") as f:
        f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(points)}\nproperty float x\n"
                f"property float y\nproperty float z\nend_header\n".encode())
        f.write(points.tobytes())
    print(f"{out}: {len(points)} particles, spacing {d}")


if __name__ == "__main__":
    main()
