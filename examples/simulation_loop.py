#!/usr/bin/env python3
"""Surfaces a particle sequence frame by frame, as a simulator's loop would: one
meniscus.Reconstructor made before the loop, called with each step's arrays, the milliseconds of
each frame printed.

    /usr/bin/python3 examples/simulation_loop.py [FOLDER] [--out DIR] [--threads N] [--preset NAME]

FOLDER holds the frames (any particle format meniscus reads, in name order; default: the two
SPlisHSPlasH frames bundled in tests/data/sph_dambreak). Here the frames come from files; in a
simulator they are its own arrays: a float32 N×3 array (NumPy, a PyTorch CPU tensor …) is read in
place, anything else converted once. With --out, each mesh is written there as frame_NNNN.ply.
"""
import argparse
import pathlib
import time

import numpy as np

import meniscus

HERE = pathlib.Path(__file__).resolve().parent


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", default=HERE.parent / "tests" / "data" / "sph_dambreak", type=pathlib.Path)
    parser.add_argument("--out", type=pathlib.Path, help="write each frame's mesh here")
    parser.add_argument("--threads", type=int, default=0, help="0: every core granted")
    parser.add_argument("--preset", default="production")
    args = parser.parse_args()
    files = sorted(f for f in args.folder.iterdir() if f.is_file() and not f.name.startswith("."))
    if not files:
        parser.error(f"{args.folder}: no frames")
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)

    surface = meniscus.Reconstructor(preset=args.preset, threads=args.threads, transfer=["velocity"])
    for step, path in enumerate(files):
        particles = meniscus.read_particles(path)  # the simulator's state at this step
        positions = np.ascontiguousarray(particles.positions, dtype=np.float32)
        velocity = particles.attributes.get("velocity", particles.attributes.get("v"))
        attributes = {"velocity": velocity} if velocity is not None else {"velocity": np.zeros_like(positions)}
        start = time.perf_counter()
        mesh = surface(positions, attributes)
        ms = (time.perf_counter() - start) * 1e3
        print(f"frame {step}: {len(positions):,} particles -> {len(mesh.triangles):,} triangles, genus "
              f"{mesh.stats['genus']}, {ms:.1f} ms (copied {mesh.stats['input']['bytes_copied']:,} input bytes)")
        if args.out:
            meniscus.write_mesh(args.out / f"frame_{step:04d}.ply", mesh)


if __name__ == "__main__":
    main()
