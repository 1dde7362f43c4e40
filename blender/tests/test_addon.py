"""Headless test of the meniscus Blender add-on (run inside Blender by run_blender.py; ctest
`blender_addon`). Registers the add-on the way Blender does, surfaces a real frame held as a
point mesh through the operator, and a two-frame sequence on disk through the frame-change
handler; each mesh must be watertight with the counts the Python module (or, without it, the
CLI) gives for the same particles and parameters. Then the same with the CLI backend forced.

Environment: MENISCUS_BLENDER_ADDON_DIR (the folder holding meniscus_blender), MENISCUS_TEST_DATA,
MENISCUS_PYTHONPATH (the module's folder, when built), MENISCUS_CLI."""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import addon_utils
import bpy
import numpy as np

sys.path.insert(0, os.environ["MENISCUS_BLENDER_ADDON_DIR"])
DATA = os.environ["MENISCUS_TEST_DATA"]
FRAME = os.path.join(DATA, "ply", "dam_break_frame_9_6859_particles.ply")
SEQUENCE_FRAMES = [os.path.join(DATA, "ply", "fluid_250_particles.ply"),
                   os.path.join(DATA, "ply", "cube_2366_particles.ply")]

addon_utils.enable("meniscus_blender", default_set=True, handle_error=None)
import meniscus_blender as addon  # noqa: E402 — after registration, as Blender loads it

assert "meniscus_blender" in bpy.context.preferences.addons, "the add-on did not register"
assert hasattr(bpy.types.Scene, "meniscus") and hasattr(bpy.ops.meniscus, "surface")
backend = addon.get_backend()
print(f"meniscus add-on backend: {backend.describe()} {backend.why}")
if os.environ.get("MENISCUS_PYTHONPATH"):
    assert backend.kind == "module", f"the Python module should be importable in Blender: {backend.why}"
else:
    assert backend.kind == "cli", backend.why


def reference_counts(positions, attributes, params):
    """(vertices, triangles) of the same job outside Blender: the Python module when importable,
    else the CLI on a PLY of the particles."""
    if backend.kind == "module":
        mesh = backend.module.reconstruct(positions, attributes, **params)
        return len(mesh.vertices), len(mesh.triangles)
    with tempfile.TemporaryDirectory() as tmp:
        addon.write_particles_ply(os.path.join(tmp, "p.ply"), positions, attributes)
        return reference_file_counts(os.path.join(tmp, "p.ply"), params)


def reference_file_counts(path, params):
    if backend.kind == "module":
        mesh = backend.module.reconstruct(backend.module.read_particles(path), **params)
        return len(mesh.vertices), len(mesh.triangles)
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "c.json"), "w") as f:
            json.dump(params, f)
        subprocess.run([os.environ["MENISCUS_CLI"], "surface", path, "-o", os.path.join(tmp, "m.ply"), "--config",
                        os.path.join(tmp, "c.json"), "--stats", os.path.join(tmp, "s.json"), "--quiet"], check=True)
        with open(os.path.join(tmp, "s.json")) as f:
            stats = json.load(f)
        return stats["vertices"], stats["triangles"]


def mesh_arrays(obj):
    mesh = obj.data
    vertices = np.zeros(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", vertices)
    loops = np.zeros(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", loops)
    totals = np.zeros(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_total", totals)
    assert np.all(totals == 3), "the surface must be made of triangles"
    return vertices.reshape(-1, 3), loops.reshape(-1, 3)


def assert_watertight(obj):
    vertices, triangles = mesh_arrays(obj)
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    directed = len(np.unique(edges, axis=0))
    edges.sort(axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert len(triangles) > 0
    assert np.all(counts == 2), f"{obj.name}: {np.count_nonzero(counts != 2)} edges not shared by two triangles"
    assert directed == len(edges), f"{obj.name}: inconsistently oriented triangles"
    # Blender's own edge list agrees: every edge borders exactly two faces.
    assert len(obj.data.edges) == len(counts)
    return len(vertices), len(triangles)


def read_ply_particles(path):
    positions, _, _, attributes = addon.read_mesh_ply(path)
    return positions, attributes


def surface_point_mesh():
    """A real frame as a point mesh (vertices only, velocity as a point attribute), surfaced by
    the operator with the panel's controls."""
    positions, attributes = read_ply_particles(FRAME)
    mesh = bpy.data.meshes.new("dam break particles")
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.ravel())
    mesh.attributes.new("velocity", "FLOAT_VECTOR", "POINT").data.foreach_set(
        "vector", attributes["velocity"].ravel())
    # A colour ramp along x as the active colour attribute (RGBA).
    span = positions[:, 0].min(), positions[:, 0].max()
    ramp = (positions[:, 0] - span[0]) / (span[1] - span[0])
    rgba = np.stack([ramp, 1 - ramp, np.full_like(ramp, 0.25), np.ones_like(ramp)], axis=1).astype(np.float32)
    colors = mesh.color_attributes.new("paint", "FLOAT_COLOR", "POINT")
    colors.data.foreach_set("color", rgba.ravel())
    mesh.color_attributes.active_color = colors
    obj = bpy.data.objects.new("dam break particles", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj

    settings = bpy.context.scene.meniscus
    settings.source = "OBJECT"
    settings.preset = "NONE"
    settings.smoothness = 0.4
    settings.detail = 1.25
    settings.erode = 0.002
    settings.min_particles = 2
    settings.use_particle_box = True
    settings.particle_box_min = (-100.0, -100.0, -100.0)  # every particle of the frame inside
    settings.particle_box_max = (100.0, 100.0, 100.0)
    settings.use_clip_box = True  # cuts the surface off the floor, capped: still watertight
    settings.clip_box_min = (-100.0, -100.0, 0.05)
    settings.clip_box_max = (100.0, 100.0, 100.0)
    settings.clip_cap = True
    settings.decimate = 0.02
    settings.transfer_velocity = True
    settings.transfer_color = True
    settings.result_name = ""
    assert bpy.ops.meniscus.surface() == {"FINISHED"}, settings.last_report
    result = bpy.data.objects[settings.result_name]
    assert result.name == "dam break particles surface"
    counts = assert_watertight(result)
    params = addon.params_from_settings(settings)
    assert sorted(params) == ["clip_box", "clip_cap", "decimate", "detail", "erode", "min_particles", "particle_box",
                              "smoothness", "transfer"]
    # Blender keeps float properties as float32.
    assert np.allclose(params["clip_box"], [-100.0, -100.0, 0.05, 100.0, 100.0, 100.0]) and params["clip_cap"]
    assert abs(params["decimate"] - 0.02) < 1e-7
    assert params["particle_box"] == [-100.0, -100.0, -100.0, 100.0, 100.0, 100.0]
    assert params["transfer"] == ["velocity", "color"]
    expected = reference_counts(positions, {"velocity": attributes["velocity"], "color": rgba[:, :3]}, params)
    assert counts == expected, f"operator gave {counts}, the reference {expected}"
    velocity = result.data.attributes["velocity"]
    assert velocity.domain == "POINT" and len(velocity.data) == counts[0]
    assert result.data.has_custom_normals
    color = result.data.color_attributes["color"]
    assert color.domain == "POINT" and result.data.color_attributes.active_color.name == "color"
    values = np.zeros(len(color.data) * 4, np.float32)
    color.data.foreach_get("color", values)
    values = values.reshape(-1, 4)
    surface_x = mesh_arrays(result)[0][:, 0]
    expected_red = np.clip((surface_x - span[0]) / (span[1] - span[0]), 0, 1)
    assert np.median(np.abs(values[:, 0] - expected_red)) < 0.05, "the colour ramp must follow x"
    assert np.allclose(values[:, 2], 0.25, atol=0.01) and np.allclose(values[:, 3], 1.0)
    print(f"operator: {settings.last_report}")
    return counts


def surface_with_a_field_method():
    """The same point mesh with the panel's Field, Smooth particles and Velocity weighted: the
    library's result for those keywords; the velocity is read for the weighting alone."""
    positions, attributes = read_ply_particles(FRAME)
    bpy.context.view_layer.objects.active = bpy.data.objects["dam break particles"]
    settings = bpy.context.scene.meniscus
    settings.source = "OBJECT"
    settings.preset = "NONE"
    settings.transfer_velocity = settings.transfer_color = False
    settings.field = "anisotropic"
    settings.smooth_particles = 0.5
    settings.velocity_weighted = True
    settings.result_name = "anisotropic surface"
    assert bpy.ops.meniscus.surface() == {"FINISHED"}, settings.last_report
    counts = assert_watertight(bpy.data.objects["anisotropic surface"])
    params = addon.params_from_settings(settings)
    assert params["field"] == "anisotropic" and params["smooth_particles"] == 0.5, params
    assert params["velocity_weighted"] is True and "transfer" not in params, params
    expected = reference_counts(positions, {"velocity": attributes["velocity"]}, params)
    assert counts == expected, f"anisotropic: operator gave {counts}, the reference {expected}"
    distance = bpy.data.objects["dam break particles surface"]
    assert counts != (len(distance.data.vertices), len(distance.data.polygons)), "the field must change the surface"
    print(f"anisotropic, velocity weighted: {settings.last_report}")
    settings.field = "distance"
    settings.smooth_particles = -1.0
    settings.velocity_weighted = False


def surface_sequence_on_frame_change(tmp):
    """Two frames on disk, surfaced by the frame_change_post handler as the frame changes."""
    for frame, source in enumerate(SEQUENCE_FRAMES, start=1):
        shutil.copy(source, os.path.join(tmp, f"fluid_{frame:04d}.ply"))
    settings = bpy.context.scene.meniscus
    settings.source = "FILES"
    settings.file_pattern = os.path.join(tmp, "fluid_####.ply")
    settings.follow_frames = True
    settings.transfer_velocity = settings.transfer_color = False
    settings.erode = 0.0
    settings.result_name = "fluid sequence"
    assert addon.on_frame_change in bpy.app.handlers.frame_change_post
    params = addon.params_from_settings(settings)
    seen = []
    for frame in (1, 2, 1):
        bpy.context.scene.frame_set(frame)
        result = bpy.data.objects.get("fluid sequence")
        assert result is not None, f"frame {frame}: the handler made no object ({settings.last_report})"
        counts = assert_watertight(result)
        expected = reference_file_counts(os.path.join(tmp, f"fluid_{frame:04d}.ply"), params)
        assert counts == expected, f"frame {frame}: handler gave {counts}, the reference {expected}"
        seen.append(counts)
        print(f"frame {frame}: {settings.last_report}")
    assert seen[0] != seen[1] and seen[0] == seen[2], "each frame must show its own particles"
    # Only one mesh datablock per result survives the updates.
    assert len([m for m in bpy.data.meshes if m.name.startswith("fluid sequence")]) == 1

    # A missing frame is reported in the panel, not raised into Blender's playback.
    bpy.context.scene.frame_set(3)
    assert settings.last_report.startswith("error: frame 3: no particle file"), settings.last_report
    settings.follow_frames = False


class FakeLayout:
    """Stands in for a UILayout (panels are not drawn in background mode): checks that every
    property the panel shows exists, and records the labels."""

    def __init__(self, labels):
        self.labels, self.active = labels, True

    def prop(self, data, name, **_):
        assert name in data.bl_rna.properties, f"the panel shows a missing property '{name}'"

    def label(self, text="", **_):
        self.labels.append(text)

    def operator(self, idname, **_):
        category, name = idname.split(".")
        assert hasattr(getattr(bpy.ops, category), name), idname

    def box(self, **_):
        return self

    row = column = box


def check_panel_draws():
    labels = []
    panel = type("Panel", (), {"layout": FakeLayout(labels)})()
    for source in ("OBJECT", "FILES"):
        bpy.context.scene.meniscus.source = source
        addon.MENISCUS_PT_panel.draw(panel, bpy.context)
    assert labels[0] == backend.describe(), labels  # the panel says which backend is in use
    prefs = bpy.context.preferences.addons["meniscus_blender"].preferences
    for name in ("backend", "python_path", "cli_path"):
        assert name in prefs.bl_rna.properties


def surface_particle_system():
    """The alive particles of an emitter's particle system (evaluated at frame 6), surfaced with
    their velocity; the reference gets the same particles read back from the depsgraph."""
    bpy.context.scene.frame_set(1)
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(0.0, 0.0, 3.0))
    emitter = bpy.context.active_object
    emitter.name = "emitter"
    emitter.modifiers.new("particles", "PARTICLE_SYSTEM")
    particle_settings = emitter.particle_systems[0].settings
    particle_settings.count = 400
    particle_settings.frame_start, particle_settings.frame_end = 1, 4
    particle_settings.lifetime = 100
    bpy.context.scene.frame_set(6)
    settings = bpy.context.scene.meniscus
    settings.source = "PARTICLES"
    settings.transfer_velocity, settings.transfer_color = True, False
    settings.erode = 0.0
    settings.result_name = ""
    assert bpy.ops.meniscus.surface() == {"FINISHED"}, settings.last_report
    result = bpy.data.objects["emitter surface"]
    counts = assert_watertight(result)
    positions, attributes = addon.particle_system_particles(emitter, bpy.context.evaluated_depsgraph_get(), settings)
    assert 50 < len(positions) <= 400 and attributes["velocity"].shape == positions.shape
    assert abs(positions[:, 2].mean() - 3.0) < 1.0, "particle positions must be in world space (around z = 3)"
    expected = reference_counts(positions, attributes, addon.params_from_settings(settings))
    assert counts == expected, f"particle system: operator gave {counts}, the reference {expected}"
    assert "velocity" in result.data.attributes
    print(f"particle system: {settings.last_report}")
    bpy.context.scene.frame_set(1)


def check_properties_follow_the_table():
    """The panel's properties of library parameters take the program's own defaults, ranges, help and
    choices (asked of the CLI here, not of the add-on's generated table)."""
    table = {p["key"]: p for p in json.loads(subprocess.run([os.environ["MENISCUS_CLI"], "info", "--parameters"],
                                                            check=True, capture_output=True, text=True).stdout)}
    rna = addon.MeniscusSettings.bl_rna.properties
    keys = addon.TABLE_KEYS + ["preset", "smoothness", "detail", "clip_cap"]
    assert {"erode", "min_particles", "decimate", "spacing", "field", "smooth_particles"} <= set(keys), keys
    for key in keys:
        p, prop = table[key], rna[key]
        assert prop.description.lower().startswith(p["help"].lower()), (key, prop.description)
        if p["type"] in ("number", "integer"):
            if p.get("default") is not None:
                assert abs(prop.default - p["default"]) < 1e-6, (key, prop.default, p["default"])
            if p.get("max") is not None:
                assert abs(prop.hard_max - p["max"]) < 1e-6 * max(1, p["max"]), (key, prop.hard_max, p["max"])
            if p.get("min") is not None:  # an open minimum (detail > 0) is the panel's own, above it
                assert prop.hard_min > p["min"] if p["min_open"] else prop.hard_min == p["min"], (key, prop.hard_min)
        elif p["type"] == "choice":
            assert [i.identifier for i in prop.enum_items if i.identifier != "NONE"] == p["choices"], key
            if p.get("default") is not None:
                assert prop.default == p["default"], key
        elif p["type"] == "flag":
            assert prop.default == p["default"], key
    print(f"{len(keys)} panel properties follow the program's table")


check_properties_follow_the_table()
check_panel_draws()
with tempfile.TemporaryDirectory(prefix="meniscus-blender-") as tmp:
    surface_particle_system()
    surface_point_mesh()
    surface_with_a_field_method()
    surface_sequence_on_frame_change(tmp)

    # The CLI fallback gives the same surfaces.
    if backend.kind == "module" and os.environ.get("MENISCUS_CLI"):
        prefs = bpy.context.preferences.addons["meniscus_blender"].preferences
        prefs.backend = "CLI"
        prefs.cli_path = os.environ["MENISCUS_CLI"]
        cli_backend = addon.get_backend()
        assert cli_backend.kind == "cli", cli_backend.why
        module_counts = [(len(o.data.vertices), len(o.data.polygons)) for o in
                         (bpy.data.objects["dam break particles surface"],)]
        bpy.context.view_layer.objects.active = bpy.data.objects["dam break particles"]
        settings = bpy.context.scene.meniscus
        settings.source = "OBJECT"
        settings.erode = 0.002
        settings.transfer_velocity = True
        settings.transfer_color = True
        settings.result_name = "via cli"
        assert bpy.ops.meniscus.surface() == {"FINISHED"}, settings.last_report
        cli_counts = assert_watertight(bpy.data.objects["via cli"])
        assert [cli_counts] == module_counts, f"CLI backend gave {cli_counts}, the module {module_counts}"
        assert "velocity" in bpy.data.objects["via cli"].data.attributes
        assert "color" in bpy.data.objects["via cli"].data.color_attributes
        print(f"CLI backend: {settings.last_report}")

    addon_utils.disable("meniscus_blender", default_set=True)
    assert addon.on_frame_change not in bpy.app.handlers.frame_change_post
    assert not hasattr(bpy.types.Scene, "meniscus")

print("meniscus Blender add-on: all checks passed")
