# meniscus for Blender: surfaces fluid particles (an object's vertices or point cloud, a particle
# system, or a file sequence on disk) into a smooth watertight mesh object, in the 3D viewport's
# sidebar (N) under the "meniscus" tab.
#
# It calls the meniscus Python module when it can be imported (Debian's Blender embeds Debian's
# python3, so the module built for /usr/bin/python3 loads; its folder is taken from the add-on
# preference "Python module folder" or the environment variable MENISCUS_PYTHONPATH), and falls
# back to running the `meniscus` CLI otherwise (preference "meniscus executable", environment
# variable MENISCUS_CLI, or `meniscus` on PATH). The panel says which one is in use.
#
# A frame_change_post handler re-surfaces the file sequence for the current frame when the
# source is "File sequence" and "Update on frame change" is on.

bl_info = {
    "name": "meniscus",
    "author": "meniscus contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > meniscus",
    "description": "Fluid particles to a smooth, watertight mesh (Williams' constrained smoothing)",
    "category": "Object",
}

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

from .parameter_table import PARAMETERS

ADDON = __name__


# --- backends ----------------------------------------------------------------------------------

class Backend:
    """The Python module (kind "module") or the CLI (kind "cli"); `why` says why the module is
    not used when it is the CLI, or why neither works when kind is None."""

    def __init__(self, kind, detail, module=None, cli=None, why=""):
        self.kind, self.detail, self.module, self.cli, self.why = kind, detail, module, cli, why

    def describe(self):
        if self.kind == "module":
            return f"Python module {self.detail}"
        if self.kind == "cli":
            return f"CLI {self.detail}"
        return "no backend"


_backend_cache = {}


def _preferences():
    addon = bpy.context.preferences.addons.get(ADDON)
    return addon.preferences if addon else None


def _module_paths(prefs):
    paths = []
    if prefs and prefs.python_path:
        paths.append(bpy.path.abspath(prefs.python_path))
    paths += [p for p in os.environ.get("MENISCUS_PYTHONPATH", "").split(os.pathsep) if p]
    return paths


def _cli_path(prefs):
    if prefs and prefs.cli_path:
        return bpy.path.abspath(prefs.cli_path)
    return os.environ.get("MENISCUS_CLI") or shutil.which("meniscus") or ""


def get_backend(refresh=False):
    """The backend to use now, by the preferences (Auto / Python module / CLI)."""
    prefs = _preferences()
    mode = prefs.backend if prefs else "AUTO"
    key = (mode, tuple(_module_paths(prefs)), _cli_path(prefs))
    if not refresh and key in _backend_cache:
        return _backend_cache[key]

    why = ""
    module = None
    if mode in {"AUTO", "MODULE"}:
        for path in reversed(key[1]):
            if path not in sys.path:
                sys.path.insert(0, path)
        try:
            import meniscus as module  # noqa: F811 — the pybind11 module
            if not hasattr(module, "reconstruct"):
                raise ImportError(f"'{module.__file__}' is not the meniscus Python module")
        except ImportError as error:
            module, why = None, f"module not importable: {error}"
    else:
        why = "CLI chosen in the preferences"

    if module is not None:
        backend = Backend("module", f"{module.__version__} ({os.path.dirname(module.__file__)})", module=module)
    else:
        cli = key[2]
        if mode != "MODULE" and cli and os.access(cli, os.X_OK):
            backend = Backend("cli", cli, cli=cli, why=why)
        else:
            missing = "the meniscus executable was not found (set it in the preferences or MENISCUS_CLI)"
            backend = Backend(None, "", why="; ".join(w for w in (why, missing if mode != "MODULE" else "") if w))
    _backend_cache[key] = backend
    return backend


def surface(positions, attributes, params, backend=None):
    """Surfaces N×3 world-space `positions` with `attributes` (name → array) using the backend.
    Returns (vertices V×3, triangles T×3, normals V×3, attributes dict, stats dict)."""
    backend = backend or get_backend()
    if backend.kind == "module":
        mesh = backend.module.reconstruct(positions, attributes, **params)
        return mesh.vertices, mesh.triangles, mesh.normals, mesh.attributes, mesh.stats
    if backend.kind == "cli":
        with tempfile.TemporaryDirectory(prefix="meniscus-") as tmp:
            source = os.path.join(tmp, "particles.ply")
            write_particles_ply(source, positions, attributes)
            return _surface_file_with_cli(backend, source, params, tmp)
    raise RuntimeError(f"meniscus: {backend.why}")


def surface_file(path, params, backend=None):
    """Surfaces a particle file on disk (any format meniscus reads)."""
    backend = backend or get_backend()
    if backend.kind == "module":
        return surface(*backend.module.read_particles(path), params, backend)
    if backend.kind == "cli":
        with tempfile.TemporaryDirectory(prefix="meniscus-") as tmp:
            return _surface_file_with_cli(backend, path, params, tmp)
    raise RuntimeError(f"meniscus: {backend.why}")


def _surface_file_with_cli(backend, source, params, tmp):
    config = os.path.join(tmp, "params.json")
    with open(config, "w") as f:
        json.dump(params, f)
    out, stats = os.path.join(tmp, "surface.ply"), os.path.join(tmp, "stats.json")
    run = subprocess.run([backend.cli, "surface", source, "-o", out, "--config", config, "--stats", stats,
                          "--quiet"], capture_output=True, text=True)
    if run.returncode != 0:
        message = run.stderr.strip().removeprefix("meniscus: error: ") or f"exit code {run.returncode}"
        raise RuntimeError(message)
    vertices, triangles, normals, attributes = read_mesh_ply(out)
    with open(stats) as f:
        return vertices, triangles, normals, attributes, json.load(f)


# --- the PLY files the CLI fallback exchanges -----------------------------------------------------

def write_particles_ply(path, positions, attributes):
    """Binary PLY of the particles: x y z, velocity as vx vy vz, color as red green blue (float,
    0..1), other 1- or 3-component attributes as name or name_x name_y name_z."""
    columns = [("x", positions[:, 0]), ("y", positions[:, 1]), ("z", positions[:, 2])]
    for name, values in (attributes or {}).items():
        values = np.asarray(values, np.float32).reshape(len(positions), -1)
        if name == "velocity" and values.shape[1] == 3:
            names = ["vx", "vy", "vz"]
        elif name == "color" and values.shape[1] >= 3:
            names, values = ["red", "green", "blue"], values[:, :3]
        elif values.shape[1] == 1:
            names = [name]
        else:
            names = [f"{name}_{i}" for i in range(values.shape[1])]
        columns += [(n, values[:, i]) for i, n in enumerate(names)]
    record = np.zeros(len(positions), dtype=[(n, "<f4") for n, _ in columns])
    for n, values in columns:
        record[n] = values
    header = "ply\nformat binary_little_endian 1.0\nelement vertex {}\n{}end_header\n".format(
        len(positions), "".join(f"property float {n}\n" for n, _ in columns))
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(record.tobytes())


_PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "<i2", "ushort": "<u2", "int": "<i4", "uint": "<u4",
              "float": "<f4", "double": "<f8", "int8": "i1", "uint8": "u1", "int16": "<i2", "uint16": "<u2",
              "int32": "<i4", "uint32": "<u4", "float32": "<f4", "float64": "<f8"}


def read_mesh_ply(path):
    """Reads a binary little-endian PLY as `meniscus surface` writes it: vertices with normals and
    attributes (vx vy vz → velocity, red green blue → color), faces (if any) as counted index
    lists of 3. Returns (positions, triangles, normals, attributes)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    lines = data[:end].decode("ascii").splitlines()
    if "format binary_little_endian 1.0" not in lines:
        raise RuntimeError(f"{path}: expected a binary little-endian PLY")
    elements, current = [], None
    for line in lines:
        words = line.split()
        if words[:1] == ["element"]:
            current = (words[1], int(words[2]), [])
            elements.append(current)
        elif words[:1] == ["property"]:
            current[2].append(words[1:])
    vertex = elements[0]
    vertex_dtype = np.dtype([(p[1], _PLY_TYPES[p[0]]) for p in vertex[2]])
    vertices = np.frombuffer(data, vertex_dtype, vertex[1], end)
    triangles = np.zeros((0, 3), np.uint32)
    if len(elements) > 1 and elements[1][0] == "face" and elements[1][1] > 0:
        face = elements[1]
        count_type, index_type = _PLY_TYPES[face[2][0][1]], _PLY_TYPES[face[2][0][2]]
        face_dtype = np.dtype([("n", count_type), ("i", index_type, 3)])
        faces = np.frombuffer(data, face_dtype, face[1], end + vertex_dtype.itemsize * vertex[1])
        if np.any(faces["n"] != 3):
            raise RuntimeError(f"{path}: expected triangles")
        triangles = faces["i"].astype(np.uint32)

    def stack(names, scale=1.0):
        return np.stack([vertices[n].astype(np.float32) / scale for n in names], axis=1)

    names = set(vertex_dtype.names)
    positions = stack(["x", "y", "z"])
    normals = stack(["nx", "ny", "nz"]) if {"nx", "ny", "nz"} <= names else np.zeros((0, 3), np.float32)
    attributes, used = {}, {"x", "y", "z", "nx", "ny", "nz"}
    if {"vx", "vy", "vz"} <= names:
        attributes["velocity"] = stack(["vx", "vy", "vz"])
        used |= {"vx", "vy", "vz"}
    if {"red", "green", "blue"} <= names:
        scale = 255.0 if vertices["red"].dtype == np.uint8 else 1.0
        attributes["color"] = stack(["red", "green", "blue"], scale)
        used |= {"red", "green", "blue"}
    for n in vertex_dtype.names:
        if n not in used:
            attributes[n] = vertices[n].astype(np.float32)
    return positions, triangles, normals, attributes


# --- particles out of Blender ----------------------------------------------------------------------

def _read_attribute(data, name, components):
    """A point-domain attribute of a mesh / point cloud as (N, components) float32, or None."""
    attribute = data.attributes.get(name) if hasattr(data, "attributes") else None
    if attribute is None or attribute.domain != "POINT":
        return None
    field = {"FLOAT": "value", "FLOAT_VECTOR": "vector", "FLOAT_COLOR": "color",
             "BYTE_COLOR": "color", "FLOAT2": "vector", "INT": "value"}.get(attribute.data_type)
    if field is None:
        return None
    width = {"value": 1, "vector": 3 if attribute.data_type == "FLOAT_VECTOR" else 2, "color": 4}[field]
    values = np.zeros(len(attribute.data) * width, np.float32)
    attribute.data.foreach_get(field, values)
    values = values.reshape(-1, width)
    return values[:, :components] if width >= components else None


def object_particles(obj, depsgraph, settings):
    """World-space positions and attributes of the evaluated object's vertices / points."""
    evaluated = obj.evaluated_get(depsgraph)
    data = evaluated.data
    if obj.type == "MESH":
        positions = np.zeros(len(data.vertices) * 3, np.float32)
        data.vertices.foreach_get("co", positions)
    elif obj.type == "POINTCLOUD":
        positions = _read_attribute(data, "position", 3)
        if positions is None:
            raise RuntimeError(f"point cloud '{obj.name}' has no position attribute")
    else:
        raise RuntimeError(f"'{obj.name}' is a {obj.type.lower()}: select a mesh or point cloud")
    positions = _to_world(positions.reshape(-1, 3), evaluated.matrix_world)

    attributes = {}
    if settings.transfer_velocity or settings.velocity_weighted:
        velocity = _read_attribute(data, "velocity", 3)
        if velocity is None:
            why = "to transfer" if settings.transfer_velocity else "for velocity-weighted smoothing"
            raise RuntimeError(f"'{obj.name}' has no point attribute 'velocity' (float vector) {why}")
        attributes["velocity"] = _rotate(velocity, evaluated.matrix_world)
    if settings.transfer_color:
        names = [settings.color_attribute] if settings.color_attribute else []
        if hasattr(data, "color_attributes") and data.color_attributes.active_color is not None:
            names.append(data.color_attributes.active_color.name)
        names += ["color", "Col", "Cd"]
        color = next((c for c in (_read_attribute(data, n, 3) for n in names) if c is not None), None)
        if color is None:
            raise RuntimeError(f"'{obj.name}' has no point colour attribute to transfer")
        attributes["color"] = color
    return positions, attributes


def particle_system_particles(obj, depsgraph, settings):
    """The alive particles of the active particle system of the evaluated object (world space)."""
    evaluated = obj.evaluated_get(depsgraph)
    system = evaluated.particle_systems.active
    if system is None:
        raise RuntimeError(f"'{obj.name}' has no particle system")
    particles = system.particles
    n = len(particles)
    positions = np.zeros(n * 3, np.float32)
    particles.foreach_get("location", positions)
    state = np.zeros(n, np.int32)
    particles.foreach_get("alive_state", state)
    alive_value = bpy.types.Particle.bl_rna.properties["alive_state"].enum_items["ALIVE"].value
    alive = state == alive_value
    if not np.any(alive):
        raise RuntimeError(f"particle system '{system.name}' has no alive particles at this frame")
    attributes = {}
    if settings.transfer_velocity or settings.velocity_weighted:
        velocity = np.zeros(n * 3, np.float32)
        particles.foreach_get("velocity", velocity)
        attributes["velocity"] = velocity.reshape(-1, 3)[alive]
    if settings.transfer_color:
        raise RuntimeError("particle systems have no colour: turn off colour transfer")
    return positions.reshape(-1, 3)[alive], attributes


def _to_world(points, matrix):
    m = np.array(matrix, np.float64)
    return (points @ m[:3, :3].T + m[:3, 3]).astype(np.float32)


def _rotate(vectors, matrix):
    m = np.array(matrix, np.float64)
    return (vectors @ m[:3, :3].T).astype(np.float32)


_FRAME_PATTERN = re.compile(r"(#+)|\{\}|%0?(\d*)d")


def sequence_path(pattern, frame):
    """The file of `frame` in a sequence pattern (`####` zero-padded to the number of `#`, `{}`,
    or printf-style `%04d`), as the CLI resolves it; a path without a placeholder is returned
    unchanged."""
    def replace(match):
        if match.group(1):
            return str(frame).zfill(len(match.group(1)))
        if match.group(0) == "{}":
            return str(frame)
        return str(frame).zfill(int(match.group(2) or 0))
    return _FRAME_PATTERN.sub(replace, bpy.path.abspath(pattern), count=1)


# --- the result mesh -------------------------------------------------------------------------------

def build_mesh(name, vertices, triangles, normals, attributes):
    """A new mesh datablock: smooth-shaded triangles, meniscus's normals as custom split normals,
    velocity as a point FLOAT_VECTOR attribute, color as a point FLOAT_COLOR attribute."""
    mesh = bpy.data.meshes.new(name)
    nv, nt = len(vertices), len(triangles)
    mesh.vertices.add(nv)
    mesh.vertices.foreach_set("co", np.ascontiguousarray(vertices, np.float32).ravel())
    mesh.loops.add(3 * nt)
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(triangles, np.int32).ravel())
    mesh.polygons.add(nt)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * nt, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(nt, 3, np.int32))
    mesh.polygons.foreach_set("use_smooth", np.ones(nt, bool))
    mesh.update(calc_edges=True)
    if len(normals) == nv and nv:
        mesh.use_auto_smooth = True
        mesh.normals_split_custom_set_from_vertices(np.asarray(normals, np.float32))
    for attribute_name, values in attributes.items():
        values = np.asarray(values, np.float32).reshape(nv, -1)
        if attribute_name == "color" and values.shape[1] in (3, 4):
            rgba = np.ones((nv, 4), np.float32)
            rgba[:, :values.shape[1]] = values
            attribute = mesh.color_attributes.new("color", "FLOAT_COLOR", "POINT")
            attribute.data.foreach_set("color", rgba.ravel())
            mesh.color_attributes.active_color = attribute
        elif values.shape[1] == 3:
            mesh.attributes.new(attribute_name, "FLOAT_VECTOR", "POINT").data.foreach_set("vector", values.ravel())
        elif values.shape[1] == 1:
            mesh.attributes.new(attribute_name, "FLOAT", "POINT").data.foreach_set("value", values.ravel())
    return mesh


def update_result_object(scene, name, arrays):
    """Puts the surface into the object `name` (created in the scene collection if needed),
    replacing its previous mesh."""
    vertices, triangles, normals, attributes, _ = arrays
    mesh = build_mesh(name, vertices, triangles, normals, attributes)
    obj = bpy.data.objects.get(name)
    if obj is None or obj.type != "MESH":
        obj = bpy.data.objects.new(name, mesh)
        scene.collection.objects.link(obj)
    else:
        old = obj.data
        obj.data = mesh
        if old.users == 0:
            bpy.data.meshes.remove(old)
    return obj


# --- settings, operator, panel, handler -----------------------------------------------------------

# --- the panel's properties, made from the program's table ---------------------------------------
# Each property of a library parameter takes its default, range and help from PARAMETERS (made from
# `meniscus info --parameters`); the panel adds only its label and display hints (a slider's soft
# range, a unit for Blender's unit system).

def _description(key):
    p = PARAMETERS[key]
    text = p["help"][:1].upper() + p["help"][1:]
    return text + (f" ({p['default']:g}: {p['zero']})" if "zero" in p else "")


def _range(key, ui):
    p = PARAMETERS[key]
    bounds = {}
    if p.get("min") is not None and "min" not in ui:
        if p.get("min_open"):
            raise ValueError(f"{key}: the table's minimum {p['min']} is open; the panel must give its own")
        bounds["min"] = p["min"]
    if p.get("max") is not None and "max" not in ui:
        bounds["max"] = p["max"]
    return bounds


def table_float(key, name, **ui):
    """A FloatProperty for the table's number `key`; `ui` adds display hints or a control's default."""
    p = PARAMETERS[key]
    assert p["type"] == "number", key
    kw = dict(name=name, description=_description(key), **_range(key, ui))
    if "default" in p:
        kw["default"] = p["default"]
    if p.get("unit") == "length":
        kw.update(unit="LENGTH", precision=4)
    kw.update(ui)
    return bpy.props.FloatProperty(**kw)


def table_int(key, name, **ui):
    p = PARAMETERS[key]
    assert p["type"] == "integer", key
    kw = dict(name=name, description=_description(key), default=p["default"],
              **{k: int(v) for k, v in _range(key, ui).items()})
    kw.update(ui)
    return bpy.props.IntProperty(**kw)


def table_flag(key, name, **ui):
    p = PARAMETERS[key]
    assert p["type"] == "flag", key
    return bpy.props.BoolProperty(name=name, description=_description(key), default=p["default"], **ui)


def table_choice(key, name, labels, first=None):
    """An EnumProperty of the table's choices, each shown with its (label, tooltip) from `labels`;
    `first` (identifier, label, tooltip) goes before them and is then the default."""
    p = PARAMETERS[key]
    assert p["type"] == "choice", key
    items = [first] if first else []
    items += [(c, *labels.get(c, (c.replace("-", " ").title(), ""))) for c in p["choices"]]
    default = first[0] if first else p["default"]
    return bpy.props.EnumProperty(name=name, items=items, default=default, description=_description(key))


PRESET_LABELS = {"preview": ("Preview", "Fast: coarse field, few sweeps"),
                 "production": ("Production", "Fine field, full smoothing"),
                 "droplets": ("Droplets", "Keeps thin sheets and small droplets")}
FIELD_LABELS = {"distance": ("Distance", "Williams' union of spheres: keeps every droplet, fastest"),
                "anisotropic": ("Anisotropic", "Yu & Turk's stretched kernels: flat sheets stay whole sheets"),
                "zhu-bridson": ("Zhu-Bridson", "Distance to the kernel-weighted mean of the particles"),
                "sph": ("SPH", "The SPH colour field at half density"),
                "metaball": ("Metaballs", "Blinn's metaballs at half the bulk value")}


class MeniscusSettings(bpy.types.PropertyGroup):
    source: bpy.props.EnumProperty(
        name="Source",
        items=[("OBJECT", "Object points", "The vertices (or points) of the active object"),
               ("PARTICLES", "Particle system", "The alive particles of the active object's particle system"),
               ("FILES", "File sequence", "Particle files on disk, one per frame")],
        default="OBJECT")
    file_pattern: bpy.props.StringProperty(
        name="Files", subtype="FILE_PATH",
        description="Particle file or sequence: fluid_####.bgeo, fluid_{}.vtk or fluid_%04d.ply")
    follow_frames: bpy.props.BoolProperty(
        name="Update on frame change", default=True,
        description="Re-surface the file sequence whenever the current frame changes")
    preset: table_choice("preset", "Preset", PRESET_LABELS, first=("NONE", "Default", "The library's defaults"))
    # smoothness is a control (it sets the sweeps) with no default of its own: 0.5 is the default schedule.
    smoothness: table_float("smoothness", "Smoothness", default=0.5, subtype="FACTOR")
    detail: table_float("detail", "Detail", min=0.25, soft_max=4.0)
    erode: table_float("erode", "Erode")
    min_particles: table_int("min_particles", "Min Particles")
    use_particle_box: bpy.props.BoolProperty(
        name="Particle Box", default=False,
        description="Surface only the particles inside a box (drop those stuck in the tank's walls)")
    particle_box_min: bpy.props.FloatVectorProperty(
        name="Box Min", size=3, default=(-1.0, -1.0, -1.0), unit="LENGTH", description="The box's lowest corner")
    particle_box_max: bpy.props.FloatVectorProperty(
        name="Box Max", size=3, default=(1.0, 1.0, 1.0), unit="LENGTH", description="The box's highest corner")
    use_clip_box: bpy.props.BoolProperty(
        name="Clip Box", default=False,
        description="Cut the finished surface by a box: the tank's walls and floor go, the water's top stays")
    clip_box_min: bpy.props.FloatVectorProperty(
        name="Clip Min", size=3, default=(-1.0, -1.0, -1.0), unit="LENGTH", description="The clip box's lowest corner")
    clip_box_max: bpy.props.FloatVectorProperty(
        name="Clip Max", size=3, default=(1.0, 1.0, 1.0), unit="LENGTH", description="The clip box's highest corner")
    clip_cap: table_flag("clip_cap", "Cap")
    decimate: table_float("decimate", "Decimate", precision=3, step=1)
    spacing: table_float("spacing", "Spacing")
    transfer_velocity: bpy.props.BoolProperty(
        name="Velocity", default=False, description="Carry the particles' velocity onto the mesh (point attribute)")
    transfer_color: bpy.props.BoolProperty(
        name="Color", default=False, description="Carry the particles' colour onto the mesh (colour attribute)")
    color_attribute: bpy.props.StringProperty(
        name="Colour attribute", default="", description="Point colour attribute of the source (empty: the active one)")
    field: table_choice("field", "Field", FIELD_LABELS)
    smooth_particles: table_float("smooth_particles", "Smooth particles", subtype="FACTOR")
    velocity_weighted: table_flag("velocity_weighted", "Velocity weighted")
    adjust_preset: bpy.props.BoolProperty(
        name="Adjust", default=False,
        description="Apply Smoothness and Detail on top of the preset (else the preset's own schedule)")
    result_name: bpy.props.StringProperty(
        name="Result", default="", description="Object that receives the surface (empty: <source> surface)")
    last_report: bpy.props.StringProperty(name="Last run", default="")


# The panel's properties that are the table's parameters and pass through as they are (preset,
# smoothness and detail go together; clip_cap only with the clip box).
TABLE_KEYS = [key for key in MeniscusSettings.__annotations__
              if key in PARAMETERS and key not in ("preset", "smoothness", "detail", "clip_cap")]


def params_from_settings(settings):
    """The reconstruct() keywords / --config keys for the panel's settings."""
    params = {}
    if settings.preset != "NONE":
        params["preset"] = settings.preset
    if settings.preset == "NONE" or settings.adjust_preset:
        params.update(smoothness=settings.smoothness, detail=settings.detail)
    for key in TABLE_KEYS:  # the rest of the table's parameters: each when it is not the table's default
        value = getattr(settings, key)
        if value != PARAMETERS[key]["default"]:
            params[key] = value
    if settings.use_particle_box:
        params["particle_box"] = [*settings.particle_box_min, *settings.particle_box_max]
    if settings.use_clip_box:
        params["clip_box"] = [*settings.clip_box_min, *settings.clip_box_max]
        if settings.clip_cap:
            params["clip_cap"] = True
    transfer = [n for n, on in (("velocity", settings.transfer_velocity), ("color", settings.transfer_color)) if on]
    if transfer:
        params["transfer"] = transfer
    return params


def run_surface(context, scene=None, frame=None):
    """Surfaces the scene's source for its current (or the given) frame into the result object.
    Returns (object, message); raises RuntimeError / the library's errors."""
    scene = scene or context.scene
    settings = scene.meniscus
    params = params_from_settings(settings)
    start = time.perf_counter()
    if settings.source == "FILES":
        if not settings.file_pattern:
            raise RuntimeError("choose a particle file or sequence")
        path = sequence_path(settings.file_pattern, scene.frame_current if frame is None else frame)
        if not os.path.exists(path):
            raise RuntimeError(f"no particle file for this frame: {path}")
        arrays = surface_file(path, params)
        default_name = "meniscus surface"
    else:
        obj = context.active_object
        if obj is None:
            raise RuntimeError("select the object holding the particles")
        depsgraph = context.evaluated_depsgraph_get()
        gather = object_particles if settings.source == "OBJECT" else particle_system_particles
        positions, attributes = gather(obj, depsgraph, settings)
        arrays = surface(positions, attributes, params)
        default_name = f"{obj.name} surface"
    result = update_result_object(scene, settings.result_name or default_name, arrays)
    if not settings.result_name:
        settings.result_name = result.name
    stats = arrays[4]
    message = (f"{stats.get('particles', 0)} particles → {len(arrays[0])} vertices, {len(arrays[1])} triangles "
               f"in {time.perf_counter() - start:.2f} s")
    settings.last_report = message
    return result, message


class MENISCUS_OT_surface(bpy.types.Operator):
    """Surface the particles into a smooth watertight mesh"""
    bl_idname = "meniscus.surface"
    bl_label = "Surface particles"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            result, message = run_surface(context)
        except (RuntimeError, ValueError, OSError, MemoryError) as error:
            context.scene.meniscus.last_report = f"error: {error}"
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, message)
        return {"FINISHED"}


class MENISCUS_OT_refresh_backend(bpy.types.Operator):
    """Look for the meniscus Python module / executable again"""
    bl_idname = "meniscus.refresh_backend"
    bl_label = "Find meniscus again"

    def execute(self, context):
        sys.modules.pop("meniscus", None)
        backend = get_backend(refresh=True)
        self.report({"INFO"}, backend.describe())
        return {"FINISHED"}


class MENISCUS_PT_panel(bpy.types.Panel):
    bl_label = "meniscus"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "meniscus"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.meniscus
        backend = get_backend()
        box = layout.box()
        box.label(text=backend.describe(), icon="CHECKMARK" if backend.kind == "module" else
                  ("CONSOLE" if backend.kind == "cli" else "ERROR"))
        if backend.why:
            box.label(text=backend.why)
        box.operator(MENISCUS_OT_refresh_backend.bl_idname, icon="FILE_REFRESH")

        layout.prop(settings, "source")
        if settings.source == "FILES":
            layout.prop(settings, "file_pattern")
            layout.prop(settings, "follow_frames")
        elif context.active_object is not None:
            layout.label(text=f"From: {context.active_object.name}", icon="OBJECT_DATA")
        row = layout.row(align=True)
        row.prop(settings, "preset")
        if settings.preset != "NONE":
            row.prop(settings, "adjust_preset", toggle=True)
        col = layout.column(align=True)
        sliders = col.column(align=True)
        sliders.active = settings.preset == "NONE" or settings.adjust_preset
        sliders.prop(settings, "smoothness")
        sliders.prop(settings, "detail")
        col.prop(settings, "erode")
        col.prop(settings, "min_particles")
        col.prop(settings, "use_particle_box")
        if settings.use_particle_box:
            col.prop(settings, "particle_box_min")
            col.prop(settings, "particle_box_max")
        col.prop(settings, "use_clip_box")
        if settings.use_clip_box:
            col.prop(settings, "clip_box_min")
            col.prop(settings, "clip_box_max")
            col.prop(settings, "clip_cap")
        col.prop(settings, "decimate")
        col.prop(settings, "spacing")
        col = layout.column(align=True)
        col.prop(settings, "field")
        col.prop(settings, "smooth_particles")
        col.prop(settings, "velocity_weighted")
        row = layout.row(align=True)
        row.label(text="Transfer")
        row.prop(settings, "transfer_color", toggle=True)
        row.prop(settings, "transfer_velocity", toggle=True)
        if settings.transfer_color and settings.source == "OBJECT":
            layout.prop(settings, "color_attribute")
        layout.prop(settings, "result_name")
        layout.operator(MENISCUS_OT_surface.bl_idname, icon="MOD_FLUIDSIM")
        if settings.last_report:
            layout.label(text=settings.last_report)


class MeniscusPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON

    backend: bpy.props.EnumProperty(
        name="Backend",
        items=[("AUTO", "Auto", "The Python module when importable, else the CLI"),
               ("MODULE", "Python module", "Only the Python module"),
               ("CLI", "CLI", "Always run the meniscus executable")],
        default="AUTO")
    python_path: bpy.props.StringProperty(
        name="Python module folder", subtype="DIR_PATH",
        description="Folder holding the meniscus package (<build>/python); also MENISCUS_PYTHONPATH")
    cli_path: bpy.props.StringProperty(
        name="meniscus executable", subtype="FILE_PATH",
        description="The meniscus CLI, used when the module cannot be imported; also MENISCUS_CLI")

    def draw(self, context):
        self.layout.prop(self, "backend")
        self.layout.prop(self, "python_path")
        self.layout.prop(self, "cli_path")
        self.layout.label(text=f"In use: {get_backend().describe()}")


@persistent
def on_frame_change(scene, depsgraph=None):
    """frame_change_post: re-surfaces the file sequence for the new frame. Errors are reported
    in the panel and on the console; they never stop playback."""
    settings = getattr(scene, "meniscus", None)
    if settings is None or settings.source != "FILES" or not settings.follow_frames or not settings.file_pattern:
        return
    try:
        _, message = run_surface(bpy.context, scene)
    except Exception as error:  # a handler must not raise
        message = f"error: frame {scene.frame_current}: {error}"
        settings.last_report = message
    print(f"meniscus: {message}")


CLASSES = (MeniscusSettings, MENISCUS_OT_surface, MENISCUS_OT_refresh_backend, MENISCUS_PT_panel,
           MeniscusPreferences)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.meniscus = bpy.props.PointerProperty(type=MeniscusSettings)
    if on_frame_change not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(on_frame_change)


def unregister():
    if on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(on_frame_change)
    del bpy.types.Scene.meniscus
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
    _backend_cache.clear()
