"""Helpers of the Python module's tests: synthetic particles and mesh checks in NumPy."""
import numpy as np


def lattice_block(n=(8, 8, 6), spacing=0.1):
    """Particles on a cubic lattice, n[0] × n[1] × n[2], spacing apart (float32)."""
    grid = np.stack(np.meshgrid(*(np.arange(k) for k in n), indexing="ij"), axis=-1).reshape(-1, 3)
    return (grid * spacing).astype(np.float32)


def edge_use_counts(triangles):
    """How many triangles use each undirected edge (one count per distinct edge)."""
    t = np.asarray(triangles, np.int64)
    edges = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    edges.sort(axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return counts


def assert_watertight(mesh):
    """Closed 2-manifold edges: every edge is shared by exactly two triangles, and every directed
    edge appears once (consistent orientation); every vertex is used."""
    t = np.asarray(mesh.triangles, np.int64)
    assert len(t) > 0
    counts = edge_use_counts(t)
    assert np.all(counts == 2), f"{np.count_nonzero(counts != 2)} edges not shared by exactly two triangles"
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed), "inconsistently oriented triangles"
    assert np.array_equal(np.unique(t), np.arange(len(mesh.vertices))), "unused or missing vertices"
    # V − E + F = 2 per closed genus-0 component; at least it must be even.
    assert (len(mesh.vertices) - len(counts) + len(t)) % 2 == 0
