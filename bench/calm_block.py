#!/usr/bin/python3
"""Calm water for the jitter benchmark: a block of particles at rest whose positions jiggle from frame
to frame, as an SPH tank's do when it settles, written as a sequence with an "id" per particle.

    /usr/bin/python3 bench/calm_block.py DIR [--frames 12] [--noise 0.03] [--size 40,40,10] [--move 0.37,0.23,0.11]
    bash bench/jitter.sh build/release DIR 'block_####.ply' -- --spacing 0.1

Particles d = 0.1 apart on a grid (each jittered ±0.1 d once), every frame independent Gaussian noise
of σ = noise·d on each axis (and, with --move, the whole block moved steadily by that many d a frame:
the jitter then left is the surface's own), each frame in its own random order (matching is by id). Binary PLY:
x, y, z, id as floats.
"""
import argparse
import os

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir")
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--noise", type=float, default=0.03, help="σ of each frame's noise, in d")
    ap.add_argument("--size", default="40,40,10", help="particles along x, y, z")
    ap.add_argument("--move", default="0,0,0", help="steady motion a frame, in d along x, y, z")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    d = 0.1
    nx, ny, nz = (int(v) for v in a.size.split(","))
    move = np.array([float(v) for v in a.move.split(",")])
    rng = np.random.default_rng(a.seed)
    grid = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"), -1).reshape(-1, 3)
    base = grid * d + rng.uniform(-0.1 * d, 0.1 * d, grid.shape)
    os.makedirs(a.dir, exist_ok=True)
    n = len(base)
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n"
              "property float z\nproperty float id\nend_header\n").encode()
    for f in range(1, a.frames + 1):
        order = rng.permutation(n)
        x = base[order] + move * d * f + rng.normal(0.0, a.noise * d, (n, 3))
        rows = np.hstack([x, order[:, None]]).astype("<f4")
        with open(os.path.join(a.dir, f"block_{f:04d}.ply"), "wb") as out:
            out.write(header + rows.tobytes())
    print(f"{a.frames} frames of {n} particles, noise {a.noise} d, moving {a.move} d a frame, in {a.dir}")


if __name__ == "__main__":
    main()
