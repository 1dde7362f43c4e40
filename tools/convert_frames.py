#!/usr/bin/python3
"""Converts the real particle frames in tests/data into binary little-endian PLY particle files.

Run with Debian's python3 (needs numpy):   /usr/bin/python3 tools/convert_frames.py
Writes tests/data/ply/<stem>.ply with x y z as float and every other per-particle array as vertex
properties (velocity -> vx vy vz, other 3-vectors -> <name>_x/_y/_z, scalars by name), so the
library's PLY reader can load frames that come from formats it does not read yet. Each input's
particle count is asserted; the byte layouts followed are those of partio/splashsurf (classic
bgeo), the VTK "Simple Legacy Formats" and "VTK XML Formats" documents, and SPHysics' IPART text.
"""

import argparse
import gzip
import re
import sys
import zlib
from pathlib import Path

import numpy as np

# file -> particle count it must hold (the bunny's name says 7705 but it holds 7706)
FRAMES = {
    "dam_break_frame_23_24389_particles.bgeo": 24389,
    "dam_break_frame_9_6859_particles.bgeo": 6859,
    "bunny_frame_14_7705_particles.vtk": 7706,
    "double_dam_break_frame_26_4732_particles.vtk": 4732,
    "cube_2366_particles.vtk": 2366,
    "free_particles_1000_particles.vtk": 1000,
    "fluid_250_particles.vtu": 250,
    "sphysics_dam_break_IPART_29814_particles.txt.gz": 29814,
}


class Frame:
    """Positions (n x 3) plus named per-particle arrays (n or n x k)."""

    def __init__(self, positions):
        self.positions = np.asarray(positions)
        self.arrays = {}

    def add(self, name, values):
        values = np.asarray(values)
        if values.ndim == 2 and values.shape[1] == 1:
            values = values[:, 0]
        assert values.shape[0] == len(self.positions), (name, values.shape, len(self.positions))
        assert name not in self.arrays, name
        self.arrays[name] = values


# --- classic bgeo (FORMATS.md section A) ---------------------------------------------------------

def read_bgeo(path):
    data = path.read_bytes()
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    assert data[:5] == b"BgeoV", "not a classic bgeo"
    version, npoints, nprims, npoint_groups, nprim_groups, npoint_attrs, nvertex_attrs, nprim_attrs, ndetail = \
        np.frombuffer(data, ">i4", 9, 5)
    assert version == 5, version
    assert nprims == 0 and npoint_groups == 0 and nprim_groups == 0, "primitives/groups are not expected in frames"
    offset = 41
    attributes = []  # (name, size, type)
    for _ in range(npoint_attrs):
        (length,) = np.frombuffer(data, ">u2", 1, offset)
        offset += 2
        name = data[offset:offset + length].decode()
        offset += length
        size = int(np.frombuffer(data, ">u2", 1, offset)[0])
        kind = int(np.frombuffer(data, ">i4", 1, offset + 2)[0])
        offset += 6
        assert kind in (0, 1, 5), f"attribute {name}: type {kind} not handled (0 float, 1 int, 5 vector)"
        offset += 4 * size  # defaults
        attributes.append((name, size, kind))
    words = 4 + sum(size for _, size, _ in attributes)
    fields = [("P", ">f4", (4,))] + [(name, ">i4" if kind == 1 else ">f4", (size,)) for name, size, kind in attributes]
    dtype = np.dtype(fields)
    assert dtype.itemsize == 4 * words
    end = offset + int(npoints) * dtype.itemsize
    assert end <= len(data), "point block truncated"
    points = np.frombuffer(data, dtype, int(npoints), offset)
    frame = Frame(points["P"][:, :3])  # P.w is the homogeneous coordinate (1.0)
    for name, size, kind in attributes:
        frame.add(name, points[name])
    return frame


# --- legacy VTK, binary big-endian (FORMATS.md section C) ----------------------------------------

VTK_TYPES = {
    "float": ">f4", "double": ">f8", "int": ">i4", "unsigned_int": ">u4", "short": ">i2",
    "unsigned_short": ">u2", "char": "i1", "unsigned_char": "u1", "long": ">i8", "unsigned_long": ">u8",
    "vtktypeint64": ">i8", "vtktypeuint64": ">u8",
}


class LegacyReader:
    def __init__(self, data):
        self.data = data
        self.pos = 0

    def line(self):
        """The next non-blank text line, or None at the end."""
        while self.pos < len(self.data) and self.data[self.pos:self.pos + 1] in (b"\n", b"\r", b" ", b"\t"):
            self.pos += 1
        if self.pos >= len(self.data):
            return None
        end = self.data.index(b"\n", self.pos)
        text = self.data[self.pos:end].decode("ascii").strip()
        self.pos = end + 1
        return text

    def array(self, vtk_type, count):
        dtype = np.dtype(VTK_TYPES[vtk_type])
        nbytes = count * dtype.itemsize
        assert self.pos + nbytes <= len(self.data), "binary block truncated"
        values = np.frombuffer(self.data, dtype, count, self.pos)
        self.pos += nbytes
        return values


def read_legacy_vtk(path):
    data = path.read_bytes()
    r = LegacyReader(data)
    assert r.line().startswith("# vtk DataFile Version")
    r.pos = data.index(b"\n", r.pos) + 1  # the title line may be anything, even blank
    assert r.line() == "BINARY", "only binary legacy VTK is converted"
    assert r.line() == "DATASET UNSTRUCTURED_GRID"
    frame = None
    section = None  # "point" or "cell" data
    npoints = 0
    while True:
        line = r.line()
        if line is None:
            break
        words = line.split()
        key = words[0]
        if key == "POINTS":
            npoints = int(words[1])
            frame = Frame(r.array(words[2], 3 * npoints).reshape(npoints, 3))
        elif key == "CELLS":
            r.array("int", int(words[2]))  # (1, i) pairs: one vertex cell per particle
        elif key == "CELL_TYPES":
            r.array("int", int(words[1]))
        elif key == "POINT_DATA":
            assert int(words[1]) == npoints
            section = "point"
        elif key == "CELL_DATA":
            section = "cell"
            ncells = int(words[1])
        elif key == "SCALARS":
            name, vtk_type = words[1], words[2]
            ncomp = int(words[3]) if len(words) > 3 else 1
            assert r.line().startswith("LOOKUP_TABLE")
            n = npoints if section == "point" else ncells
            values = r.array(vtk_type, n * ncomp).reshape(n, ncomp)
            if section == "point":
                frame.add(name, values)
        elif key == "VECTORS":
            n = npoints if section == "point" else ncells
            values = r.array(words[2], 3 * n).reshape(n, 3)
            if section == "point":
                frame.add(words[1], values)
        elif key == "FIELD":
            for _ in range(int(words[2])):
                name, ncomp, ntuples, vtk_type = r.line().split()
                values = r.array(vtk_type, int(ncomp) * int(ntuples)).reshape(int(ntuples), int(ncomp))
                if section == "point":
                    frame.add(name, values)
        else:
            raise AssertionError(f"{path.name}: unexpected legacy VTK keyword {key!r}")
    assert frame is not None, "no POINTS"
    return frame


# --- VTK XML .vtu, appended raw, zlib, UInt64 headers (FORMATS.md section C) ----------------------

VTU_TYPES = {"Float32": "<f4", "Float64": "<f8", "Int32": "<i4", "Int64": "<i8", "UInt8": "u1", "UInt32": "<u4",
             "UInt64": "<u8", "Int8": "i1", "Int16": "<i2", "UInt16": "<u2"}


def read_vtu(path):
    data = path.read_bytes()
    split = data.index(b"<AppendedData")
    xml = data[:split].decode()
    head = re.search(r"<VTKFile([^>]*)>", xml).group(1)
    assert 'byte_order="LittleEndian"' in head and 'header_type="UInt64"' in head, head
    assert 'compressor="vtkZLibDataCompressor"' in head, head
    tag = data[split:data.index(b">", split) + 1].decode()
    assert 'encoding="raw"' in tag, tag
    base = data.index(b"_", split + len(tag)) + 1
    npoints = int(re.search(r'NumberOfPoints="(\d+)"', xml).group(1))

    def attributes(element):
        return dict(re.findall(r'(\w+)="([^"]*)"', element))

    def decode(attrs):
        assert attrs["format"] == "appended", attrs
        offset = base + int(attrs["offset"])
        nblocks = int(np.frombuffer(data, "<u8", 1, offset)[0])
        header = np.frombuffer(data, "<u8", 3 + nblocks, offset)
        sizes = header[3:]
        pos = offset + 8 * (3 + nblocks)
        raw = b""
        for size in sizes:
            raw += zlib.decompress(data[pos:pos + int(size)])
            pos += int(size)
        expected = int(header[1]) * (nblocks - 1) + int(header[2]) if nblocks else 0
        assert len(raw) == expected, (len(raw), expected)
        ncomp = int(attrs.get("NumberOfComponents", "1"))
        values = np.frombuffer(raw, VTU_TYPES[attrs["type"]])
        assert values.size == npoints * ncomp, (attrs["Name"], values.size)
        return values.reshape(npoints, ncomp)

    points_xml = re.search(r"<Points>(.*?)</Points>", xml, re.S).group(1)
    frame = Frame(decode(attributes(re.search(r"<DataArray([^>]*)/?>", points_xml).group(1))))
    point_data = re.search(r"<PointData[^>]*>(.*?)</PointData>", xml, re.S)
    if point_data:
        for element in re.findall(r"<DataArray([^>]*)/?>", point_data.group(1)):
            attrs = attributes(element)
            frame.add(attrs["Name"], decode(attrs))
    return frame


# --- SPHysics IPART text: x y z u v w rho p mass ---------------------------------------------------

def read_sphysics(path):
    with gzip.open(path, "rt") as f:
        table = np.loadtxt(f, dtype=np.float64)
    assert table.ndim == 2 and table.shape[1] == 9, table.shape
    frame = Frame(table[:, 0:3])
    frame.add("velocity", table[:, 3:6])
    frame.add("density", table[:, 6])
    frame.add("pressure", table[:, 7])
    frame.add("mass", table[:, 8])
    return frame


# --- PLY output ----------------------------------------------------------------------------------

def ply_columns(name, values):
    """(property name, PLY type, numpy dtype, column) for one named array."""
    if np.issubdtype(values.dtype, np.floating):
        ply_type, dtype = "float", "<f4"
    elif np.issubdtype(values.dtype, np.unsignedinteger):
        ply_type, dtype = "uint", "<u4"
    else:
        ply_type, dtype = "int", "<i4"
    if ply_type != "float":
        info = np.iinfo(dtype)
        assert values.min() >= info.min and values.max() <= info.max, f"{name} does not fit {ply_type}"
    if values.ndim == 1:
        return [(name, ply_type, dtype, values)]
    k = values.shape[1]
    if name == "velocity" and k == 3:
        names = ["vx", "vy", "vz"]
    elif k == 3:
        names = [f"{name}_x", f"{name}_y", f"{name}_z"]
    else:
        names = [f"{name}_{i}" for i in range(k)]
    return [(n, ply_type, dtype, values[:, i]) for i, n in enumerate(names)]


def write_ply(path, frame, source_name):
    n = len(frame.positions)
    columns = [("x", "float", "<f4", frame.positions[:, 0]), ("y", "float", "<f4", frame.positions[:, 1]),
               ("z", "float", "<f4", frame.positions[:, 2])]
    for name, values in frame.arrays.items():
        columns += ply_columns(name, values)
    names = [c[0] for c in columns]
    assert len(set(names)) == len(names), names
    record = np.zeros(n, dtype=[(c[0], c[2]) for c in columns])
    for name, _, dtype, values in columns:
        record[name] = values.astype(dtype)
    header = ["ply", "format binary_little_endian 1.0", f"comment converted from {source_name} by tools/convert_frames.py",
              f"element vertex {n}"]
    header += [f"property {ply_type} {name}" for name, ply_type, _, _ in columns]
    header.append("end_header")
    tmp = path.with_name("." + path.name + ".tmp")
    with open(tmp, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(record.tobytes())
    tmp.replace(path)


def stem(name):
    for suffix in (".txt.gz", ".bgeo", ".vtk", ".vtu"):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    raise AssertionError(name)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(__file__).resolve().parent.parent / "tests" / "data",
                        help="folder holding the original frames (default: tests/data)")
    args = parser.parse_args()
    out_dir = args.data / "ply"
    out_dir.mkdir(exist_ok=True)
    readers = {".bgeo": read_bgeo, ".vtk": read_legacy_vtk, ".vtu": read_vtu, ".gz": read_sphysics}
    for name, count in FRAMES.items():
        source = args.data / name
        frame = readers[source.suffix](source)
        n = len(frame.positions)
        assert n == count, f"{name}: {n} particles, expected {count}"
        assert np.isfinite(frame.positions).all(), f"{name}: non-finite coordinates"
        target = out_dir / (stem(name) + ".ply")
        write_ply(target, frame, name)
        attrs = ", ".join(f"{k}{'' if v.ndim == 1 else '[%d]' % v.shape[1]}" for k, v in frame.arrays.items())
        print(f"{target.relative_to(args.data)}: {n} particles; {attrs or 'positions only'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
