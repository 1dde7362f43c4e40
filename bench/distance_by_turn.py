#!/usr/bin/python3
"""How far another mesh lies from a reference mesh, by how flat the reference is there: random
points on the reference's triangles (area-weighted), the distance from each to the other mesh (VTK's
cell locator: surface_distance.distances), in units of d, binned by how far the triangle's
normal turns from its corners' (area-weighted vertex normals): under 1° is flat. Prints one
markdown row a bin: the share of the area, the median, 90th and 99th percentile.

    distance_by_turn.py REFERENCE.ply OTHER.ply SPACING [SAMPLES] [LABEL]
"""
import sys

import numpy as np

from surface_distance import distances, load, samples_on

BINS = ((0, 1), (1, 2), (2, 4), (4, 8), (8, 180))


def turn_degrees(points, cells):
    """Each triangle's largest angle between its normal and its corners' vertex normals."""
    a, b, c = (points[cells[:, k]] for k in range(3))
    face = np.cross(b - a, c - a)
    vertex = np.zeros_like(points)
    for k in range(3):
        np.add.at(vertex, cells[:, k], face)
    vertex /= np.maximum(np.linalg.norm(vertex, axis=1), 1e-300)[:, None]
    unit = face / np.maximum(np.linalg.norm(face, axis=1), 1e-300)[:, None]
    cosine = np.min([np.sum(vertex[cells[:, k]] * unit, axis=1) for k in range(3)], axis=0)
    return np.degrees(np.arccos(np.clip(cosine, -1, 1)))


def main():
    _, points, cells = load(sys.argv[1])
    other = load(sys.argv[2])[0]
    spacing = float(sys.argv[3])
    count = int(sys.argv[4]) if len(sys.argv) > 4 else 40000
    label = sys.argv[5] if len(sys.argv) > 5 else sys.argv[2]
    where, pick = samples_on(points, cells, count, np.random.default_rng(1))
    distance = distances(where, other) / spacing
    turn = turn_degrees(points, cells)[pick]
    for lo, hi in BINS:
        inside = (turn >= lo) & (turn < hi)
        if not inside.any():
            continue
        q = np.percentile(distance[inside], (50, 90, 99))
        span = f"{lo}–{hi}°" if hi < 180 else f"≥ {lo}°"
        print(f"| {label} | {span} | {inside.mean():.2f} | {q[0]:.3f} | {q[1]:.3f} | {q[2]:.3f} |")


if __name__ == "__main__":
    main()
