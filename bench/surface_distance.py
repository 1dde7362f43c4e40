#!/usr/bin/python3
"""The largest distance between two triangle meshes, measured independently of meniscus (VTK's
cell locator, exact point-triangle distances): from every vertex and from random points on the
triangles of each mesh (area-weighted, SAMPLES per mesh) to the other mesh. Prints JSON.

    surface_distance.py FULL.ply SIMPLIFIED.ply [SAMPLES]
"""
import json
import sys

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy


def load(path):
    reader = vtk.vtkPLYReader()
    reader.SetFileName(path)
    reader.Update()
    mesh = reader.GetOutput()
    points = vtk_to_numpy(mesh.GetPoints().GetData()).astype(np.float64)
    cells = vtk_to_numpy(mesh.GetPolys().GetData()).reshape(-1, 4)[:, 1:]
    return mesh, points, cells


def samples_on(points, cells, count, rng):
    """Random points on the triangles, area-weighted, and the triangle each lies on."""
    a, b, c = points[cells[:, 0]], points[cells[:, 1]], points[cells[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    pick = rng.choice(len(cells), size=count, p=area / area.sum())
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    return a[pick] + u[:, None] * (b[pick] - a[pick]) + v[:, None] * (c[pick] - a[pick]), pick


def samples(points, cells, count, rng):
    return samples_on(points, cells, count, rng)[0]


def distances(points, target):
    """The distance from each point to the mesh `target` (VTK's cell locator, exact)."""
    locator = vtk.vtkStaticCellLocator()
    locator.SetDataSet(target)
    locator.BuildLocator()
    closest, cell, sub, d2 = [0.0, 0.0, 0.0], vtk.reference(0), vtk.reference(0), vtk.reference(0.0)
    out = np.empty(len(points))
    for i, p in enumerate(points):
        locator.FindClosestPoint(p, closest, cell, sub, d2)
        out[i] = float(d2)
    return np.sqrt(out)


def farthest(points, target):
    return float(distances(points, target).max())


def main():
    full_mesh, full_points, full_cells = load(sys.argv[1])
    simple_mesh, simple_points, simple_cells = load(sys.argv[2])
    count = int(sys.argv[3]) if len(sys.argv) > 3 else 100000
    rng = np.random.default_rng(1)
    full_to_simple = farthest(np.concatenate([full_points, samples(full_points, full_cells, count, rng)]), simple_mesh)
    simple_to_full = farthest(np.concatenate([simple_points, samples(simple_points, simple_cells, count, rng)]), full_mesh)
    print(json.dumps({"full_to_simplified": full_to_simple, "simplified_to_full": simple_to_full,
                      "hausdorff": max(full_to_simple, simple_to_full), "samples": count}))


if __name__ == "__main__":
    main()
