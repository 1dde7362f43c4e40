#!/usr/bin/python3
"""Whether two meshes are the same surface bit for bit, whatever their vertex and triangle order:
the same vertex positions (as float32 bit patterns), the same triangles (as triples of positions,
turned to start at their smallest vertex, orientation kept), closed and edge-manifold.

    same_mesh.py A.ply B.ply                 exit 0 when they are, 1 (with what differs) when not
    same_mesh.py --attributes A.ply B.ply    also every per-vertex attribute but the normals, bit for bit
"""
import sys

import meshio
import numpy as np


def canonical(path, attributes=None):
    m = meshio.read(path)
    v = np.ascontiguousarray(m.points.astype(np.float32))
    t = np.concatenate([c.data for c in m.cells if c.type == "triangle"]).astype(np.int64)
    keys = v.view(np.uint32).reshape(-1, 3)
    order = np.lexsort((keys[:, 2], keys[:, 1], keys[:, 0]))
    if len(np.unique(keys, axis=0)) != len(keys):
        sys.exit(f"{path}: two vertices at one position")
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    t = rank[t]
    for _ in range(2):  # turn each triangle to start at its smallest vertex
        turn = (t[:, 0] > t[:, 1]) | (t[:, 0] > t[:, 2])
        t[turn] = np.roll(t[turn], -1, axis=1)
    t = t[np.lexsort((t[:, 2], t[:, 1], t[:, 0]))]
    if attributes is not None:
        for name, values in m.point_data.items():
            if name not in ("nx", "ny", "nz", "Normals", "normals"):
                attributes[name] = np.ascontiguousarray(np.asarray(values)[order]).view(np.uint8)
    return keys[order], t


def edge_counts(t):
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return counts


def main():
    args = [a for a in sys.argv[1:] if a != "--attributes"]
    with_attributes = len(args) < len(sys.argv) - 1
    aa, ab = ({}, {}) if with_attributes else (None, None)
    (va, ta), (vb, tb) = canonical(args[0], aa), canonical(args[1], ab)
    if va.shape != vb.shape or ta.shape != tb.shape:
        sys.exit(f"counts differ: {len(va)} vertices, {len(ta)} triangles against {len(vb)}, {len(tb)}")
    if not np.array_equal(va, vb):
        sys.exit(f"{int(np.any(va != vb, axis=1).sum())} vertex positions differ")
    if not np.array_equal(ta, tb):
        sys.exit(f"{int(np.any(ta != tb, axis=1).sum())} triangles differ")
    if with_attributes:
        if sorted(aa) != sorted(ab) or not aa:
            sys.exit(f"attributes differ: {sorted(aa)} against {sorted(ab)}")
        for name in aa:
            if not np.array_equal(aa[name], ab[name]):
                sys.exit(f"attribute {name} differs")
    counts = edge_counts(ta)
    if not np.all(counts == 2):
        sys.exit(f"not closed and manifold: {int((counts != 2).sum())} edges not in exactly two triangles")
    extra = f" and {len(aa)} attribute arrays" if with_attributes else ""
    print(f"same: {len(va)} vertices, {len(ta)} triangles{extra}, bit for bit; closed and manifold")


if __name__ == "__main__":
    main()
