#!/usr/bin/python3
"""The cost of a sequence's flicker measure on the frames that jump.

Each case is a short sequence of real frames from tests/data (or frames made from them: moved
far away, one particle). It is surfaced one frame at a time, then as a sequence (which also
measures each frame's flicker against the one before), and the table gives both wall times,
their ratio, and the flicker's own time and work from the sequence's --stats files.

    /usr/bin/python3 bench/flicker.py [--cli build/release/meniscus] [--repeat 3]
"""
import argparse
import json
import pathlib
import subprocess
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data" / "ply"
DAM_9 = DATA / "dam_break_frame_9_6859_particles.ply"
DAM_23 = DATA / "dam_break_frame_23_24389_particles.ply"
DOUBLE_DAM = DATA / "double_dam_break_frame_26_4732_particles.ply"
BUNNY = DATA / "bunny_frame_14_7705_particles.ply"
HOUDINI = ROOT / "tests" / "data" / "houdini_pop_splatter_13883_points.bgeo.sc"


def read_xyz(path):
    """x, y, z of a binary little-endian PLY whose vertex properties are 4-byte, x y z first."""
    raw = path.read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    lines = raw[:end].decode().splitlines()
    props = [line.split() for line in lines if line.startswith("property ")]
    assert "format binary_little_endian 1.0" in lines, path
    assert [p[-1] for p in props[:3]] == ["x", "y", "z"] and all(p[1] in ("float", "int", "uint") for p in props), path
    count = int(next(line for line in lines if line.startswith("element vertex")).split()[2])
    rows = np.frombuffer(raw, dtype="<f4", count=len(props) * count, offset=end).reshape(count, len(props))
    return rows[:, :3].copy()


def write_xyz(path, xyz):
    xyz = np.ascontiguousarray(xyz, dtype="<f4")
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(xyz)}\n"
              "property float x\nproperty float y\nproperty float z\nend_header\n")
    path.write_bytes(header.encode() + xyz.tobytes())


def cases():
    dam = read_xyz(DAM_23)
    one = np.array([[0.5, 0.3, 0.2]], dtype=np.float32)
    return [
        ("four frames of three scenes", [read_xyz(p) for p in (DAM_23, DOUBLE_DAM, DAM_9, BUNNY)], []),
        ("two unrelated frames", [dam, read_xyz(DOUBLE_DAM)], []),
        ("frames 9 and 23 of one dam break", [read_xyz(DAM_9), dam], []),
        ("a frame moved 0.1 d (ordinary motion)", [dam, dam + np.float32([0.005, 0, 0])], ["--spacing", "0.05"]),
        ("a frame far from the previous one", [dam, dam + np.float32([100, 0, 0])], []),
        ("one particle after a full frame", [dam, one], ["--spacing", "0.05"]),
        ("a full frame after one particle", [one, dam], ["--spacing", "0.05"]),
        # 13,883 points, mostly lone particles: 900k vertices, cheap to surface per vertex.
        ("a Houdini cache frame twice", [HOUDINI, HOUDINI], []),
    ]


def timed(command):
    t0 = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cli", default=str(ROOT / "build" / "release" / "meniscus"))
    parser.add_argument("--repeat", type=int, default=3, help="runs of each measurement; the fastest counts")
    a = parser.parse_args()
    print("| case | frames | one by one (s) | sequence (s) | ratio | flicker (s) | flicker / surfacing | tests per vertex | beyond the cap |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, frames, extra in cases():
        with tempfile.TemporaryDirectory() as tmp:
            tmp = pathlib.Path(tmp)
            ext = "".join(frames[0].suffixes) if isinstance(frames[0], pathlib.Path) else ".ply"
            for i, frame in enumerate(frames, 1):
                if isinstance(frame, pathlib.Path):
                    (tmp / f"f_{i:04d}{ext}").write_bytes(frame.read_bytes())
                else:
                    write_xyz(tmp / f"f_{i:04d}{ext}", frame)
            single = min(sum(timed([a.cli, "surface", str(tmp / f"f_{i:04d}{ext}"), "-o", str(tmp / "one.ply"), "-q", *extra])
                             for i in range(1, len(frames) + 1)) for _ in range(a.repeat))
            sequence = min(timed([a.cli, "surface", str(tmp / f"f_####{ext}"), "-o", str(tmp / "m_####.ply"), "-q",
                                  "--stats", str(tmp / "s_####.json"), *extra]) for _ in range(a.repeat))
            stats = [json.loads((tmp / f"s_{i:04d}.json").read_text()) for i in range(1, len(frames) + 1)]
            flicker = [s["flicker"] for s in stats[1:]]
            seconds = sum(f["seconds"] for f in flicker)
            surfacing = sum(s["total_seconds"] for s in stats)
            vertices = sum(s["vertices"] for s in stats[1:])
            tests = sum(f["triangle_tests"] for f in flicker)
            beyond = sum(f["beyond_cap"] for f in flicker)
            print(f"| {name} | {len(frames)} | {single:.2f} | {sequence:.2f} | {sequence / single:.2f} | {seconds:.3f} | "
                  f"{seconds / surfacing:.0%} | {tests / max(vertices, 1):.1f} | {beyond / max(vertices, 1):.0%} |")


if __name__ == "__main__":
    main()
