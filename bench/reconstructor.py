#!/usr/bin/env python3
"""Small frames in a simulation's loop: the time per frame of meniscus.reconstruct() and of a
meniscus.Reconstructor made once, per particle count, on one thread, production preset.

    PYTHONPATH=build/release/python /usr/bin/python3 bench/reconstructor.py [--counts 100,1000,10000,100000]

The frames are jittered blocks of about N particles (a simulator's float32 N×3 array, a fresh
jitter each frame); each is timed over several frames after one warm-up: wall and CPU time per
frame (median), the input bytes each call copied (float64 input, as NumPy's defaults make, is
converted; float32 is read in place), the triangles, and the share of the frame in the
smoothing's sweeps (the stage times of --stats).
"""
import argparse
import statistics
import time

import numpy as np

import meniscus


def block(n, seed):
    k = max(2, round(n ** (1 / 3)))
    grid = np.stack(np.meshgrid(*(np.arange(k),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    return (grid + rng.uniform(-0.2, 0.2, grid.shape)).astype(np.float32)


def timed(call, frames):
    wall, cpu, meshes = [], [], []
    for x in frames:
        w, c = time.perf_counter(), time.process_time()
        meshes.append(call(x))
        wall.append(time.perf_counter() - w)
        cpu.append(time.process_time() - c)
    return statistics.median(wall) * 1e3, statistics.median(cpu) * 1e3, meshes[-1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", default="10,100,1000,10000,100000")
    parser.add_argument("--preset", default="production")
    args = parser.parse_args()
    params = dict(spacing=1.0, threads=1, preset=args.preset)
    print(f"meniscus {meniscus.__version__}, preset {args.preset}, one thread; times per frame in ms (median)")
    print("| particles | triangles | reconstruct(float64) wall / CPU | reconstruct(float32) wall / CPU "
          "| Reconstructor(float32) wall / CPU | bytes copied per frame: float64 / float32 | smoothing share |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for n in (int(c) for c in args.counts.split(",")):
        reps = max(3, min(50, 200000 // max(n, 1)))
        frames = [block(n, seed) for seed in range(reps + 1)]
        surface = meniscus.Reconstructor(**params)
        surface(frames[0])  # warm-up (first-touch pages, lazy symbols) for all three
        meniscus.reconstruct(frames[0], **params)
        w64, c64, m64 = timed(lambda x: meniscus.reconstruct(x.astype(np.float64), **params), frames[1:])
        w32, c32, m32 = timed(lambda x: meniscus.reconstruct(x, **params), frames[1:])
        wr, cr, mr = timed(surface, frames[1:])
        assert mr.vertices.tobytes() == m32.vertices.tobytes() == m64.vertices.tobytes()
        stages = mr.stats["stages"]
        share = stages.get("smooth", 0) / max(sum(stages.values()), 1e-12)
        print(f"| {len(frames[0]):,} | {len(mr.triangles):,} | {w64:.2f} / {c64:.2f} | {w32:.2f} / {c32:.2f} "
              f"| {wr:.2f} / {cr:.2f} | {m64.stats['input']['bytes_copied']:,} / {mr.stats['input']['bytes_copied']:,} "
              f"| {100 * share:.0f} % |")


if __name__ == "__main__":
    main()
