"""meniscus.reconstruct: watertight meshes, the CLI's counts, dtypes and shapes, zero copy,
the GIL released, progress, attribute transfer."""
import gc
import json
import threading

import numpy as np
import pytest

import meniscus
from support import assert_watertight, lattice_block

FRAME = "ply/dam_break_frame_9_6859_particles.ply"


def test_version_matches_the_cli(cli):
    assert meniscus.__version__ == cli("--version").stdout.strip().split()[-1]


def test_lattice_block_is_watertight_with_the_expected_layout():
    positions = lattice_block((16, 16, 5))
    mesh = meniscus.reconstruct(positions, spacing=0.1)
    assert_watertight(mesh)
    v, t, n = mesh.vertices, mesh.triangles, mesh.normals
    assert v.dtype == np.float32 and v.ndim == 2 and v.shape[1] == 3
    assert t.dtype == np.uint32 and t.ndim == 2 and t.shape[1] == 3
    assert n.dtype == np.float32 and n.shape == v.shape
    assert np.allclose(np.linalg.norm(n, axis=1), 1, atol=1e-4)
    assert mesh.stats["vertices"] == len(v) and mesh.stats["triangles"] == len(t)
    assert mesh.stats["particles"] == len(positions)
    assert mesh.params["spacing"] == pytest.approx(0.1)
    assert mesh.params["voxel_size"] == pytest.approx(0.05)
    # Flat top face: the vertices above the top particle layer lie in one plane.
    lo, hi = positions.min(axis=0) + 0.4, positions.max(axis=0) - 0.4  # away from the rounded edges
    inner = np.all((v[:, :2] > lo[:2]) & (v[:, :2] < hi[:2]), axis=1)
    top = v[inner & (v[:, 2] > positions[:, 2].max() + 0.025)]
    assert len(top) > 100 and np.std(top[:, 2]) < 0.005 * 0.1  # flat to 0.5 % of the spacing
    assert 0.05 <= np.mean(top[:, 2]) - positions[:, 2].max() <= 0.1  # between r_inner and r_outer
    # Every vertex stays outside the inner radius of the nearest particle and within the block's hull.
    assert np.all(v.min(axis=0) > positions.min(axis=0) - 0.1 - 1e-4)
    assert np.all(v.max(axis=0) < positions.max(axis=0) + 0.1 + 1e-4)


def test_float64_and_list_inputs_give_the_same_mesh():
    positions = lattice_block((5, 5, 5))
    a = meniscus.reconstruct(positions, spacing=0.1, threads=1)
    b = meniscus.reconstruct(positions.astype(np.float64), spacing=0.1, threads=1)
    c = meniscus.reconstruct(positions.tolist(), spacing=0.1, threads=1)
    for other in (b, c):
        assert np.array_equal(a.triangles, other.triangles)
        assert np.array_equal(a.vertices, other.vertices)


def test_counts_equal_the_clis_on_a_lattice_block(cli, tmp_path):
    positions = lattice_block()
    np.save(tmp_path / "block.npy", positions)
    cli("surface", tmp_path / "block.npy", "-o", tmp_path / "block.ply", "--spacing", "0.1", "--steps-a", "10",
        "--extract", "cubes", "--stats", tmp_path / "stats.json", "--quiet")
    expected = json.loads((tmp_path / "stats.json").read_text())
    mesh = meniscus.reconstruct(positions, spacing=0.1, steps_a=10, extract="cubes")
    assert (len(mesh.vertices), len(mesh.triangles)) == (expected["vertices"], expected["triangles"])
    assert mesh.params == expected["parameters"] | {"threads": mesh.params["threads"]}
    written = meniscus.read_mesh(tmp_path / "block.ply")
    assert np.array_equal(written.triangles, mesh.triangles)
    assert np.allclose(written.vertices, mesh.vertices, atol=1e-6)


def test_real_frame_is_watertight_with_the_clis_counts(cli, data, tmp_path):
    particles = meniscus.read_particles(data / FRAME)
    mesh = meniscus.reconstruct(particles, preset="preview", smoothness=0.7, detail=1.25, transfer=["velocity"])
    assert_watertight(mesh)
    cli("surface", data / FRAME, "-o", tmp_path / "frame.ply", "--preset", "preview", "--smoothness", "0.7",
        "--detail", "1.25", "--transfer", "velocity", "--stats", tmp_path / "stats.json", "--quiet")
    expected = json.loads((tmp_path / "stats.json").read_text())
    assert (len(mesh.vertices), len(mesh.triangles)) == (expected["vertices"], expected["triangles"])
    assert mesh.stats["removed_voids"] == expected["removed_voids"]
    assert mesh.attributes["velocity"].shape == (len(mesh.vertices), 3)


def test_arrays_share_memory_with_the_result():
    mesh = meniscus.reconstruct(lattice_block((5, 5, 5)), spacing=0.1, transfer=["value"],
                                attributes={"value": np.arange(125, dtype=np.float32)})
    arrays = [mesh.vertices, mesh.triangles, mesh.normals, mesh.attributes["value"]]
    owner = mesh.vertices.base
    assert owner is not None
    for a in arrays:
        assert not a.flags.owndata
        assert a.base is owner  # one capsule owns the whole C++ mesh
    vertices = mesh.vertices
    expected = vertices.copy()
    del mesh, arrays, owner
    gc.collect()
    assert np.array_equal(vertices, expected)  # the C++ mesh lives as long as any of its arrays


def test_the_gil_is_released_while_reconstructing(data):
    """A Python thread polls the progress while reconstruct runs and must see the smoothing stage
    before the normals stage has begun. The progress callback is a builtin (dict.__setitem__), so
    no Python bytecode runs on the reconstructing thread: were the GIL held, the poller could
    not run at all until reconstruct returned, and would see every stage finished."""
    particles = meniscus.read_particles(data / FRAME)
    progress = {}
    first_sight = []
    done = threading.Event()

    def poller():
        while not done.is_set():
            if "smooth" in progress:
                first_sight.append(dict(progress))
                return

    thread = threading.Thread(target=poller)
    thread.start()
    try:
        mesh = meniscus.reconstruct(particles, progress=progress.__setitem__, threads=1)
    finally:
        done.set()
        thread.join()
    assert len(mesh.triangles) > 0 and progress["normals"] == 1.0
    assert first_sight, "the poller never saw the smoothing stage"
    assert "normals" not in first_sight[0], f"the poller only ran after reconstruct: {first_sight[0]}"


def test_ctrl_c_cancels_at_the_next_stage(data):
    """KeyboardInterrupt (here from _thread.interrupt_main, as Ctrl-C) stops reconstruct at the
    next stage boundary, without a progress callback of one's own."""
    import _thread

    particles = meniscus.read_particles(data / FRAME)
    progress = {}
    done = threading.Event()

    def interrupter():
        while not done.is_set():
            if "grid" in progress:
                _thread.interrupt_main()
                return

    thread = threading.Thread(target=interrupter)
    thread.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            meniscus.reconstruct(particles, progress=progress.__setitem__, threads=1)
    finally:
        done.set()
        thread.join()
    assert "normals" not in progress  # stopped before the end


def test_progress_reports_every_stage_in_order():
    events = []
    meniscus.reconstruct(lattice_block((4, 4, 4)), spacing=0.1, progress=lambda s, f: events.append((s, f)))
    stages = [s for s, f in events if f == 0.0]
    assert stages[:5] == ["parameters", "grid", "field", "extract", "voids"]
    assert "smooth" in stages and stages[-1] == "normals"
    assert len(stages) == len(set(stages))
    for stage in stages:  # each stage from 0 to 1, in one run of events, never going back
        fractions = [f for s, f in events if s == stage]
        first = events.index((stage, 0.0))
        assert events[first:first + len(fractions)] == [(stage, f) for f in fractions]
        assert fractions[-1] == 1.0 and fractions == sorted(fractions)


def test_an_exception_in_progress_cancels_and_propagates():
    class Stop(Exception):
        pass

    def progress(stage, fraction):
        if stage == "field":
            raise Stop("cancelled at " + stage)

    with pytest.raises(Stop, match="cancelled at field"):
        meniscus.reconstruct(lattice_block((4, 4, 4)), spacing=0.1, progress=progress)


def test_colour_ramp_is_transferred_onto_the_vertices():
    positions = lattice_block((10, 6, 6))
    x = positions[:, 0] / positions[:, 0].max()
    color = np.stack([x, 1 - x, np.full_like(x, 0.25)], axis=1)
    ids = np.arange(len(positions), dtype=np.int64)
    mesh = meniscus.reconstruct(positions, {"color": color, "id": ids}, spacing=0.1, transfer=["color"])
    transferred = mesh.attributes["color"]
    assert set(mesh.attributes) == {"color"}
    assert transferred.shape == (len(mesh.vertices), 3) and transferred.dtype == np.float32
    expected_red = np.clip(mesh.vertices[:, 0] / positions[:, 0].max(), 0, 1)
    assert np.max(np.abs(transferred[:, 0] - expected_red)) < 0.15
    assert np.allclose(transferred[:, 0] + transferred[:, 1], 1, atol=1e-4)
    assert np.allclose(transferred[:, 2], 0.25, atol=1e-5)


def test_min_particles_drops_the_strays():
    block = np.stack(np.meshgrid(*(np.arange(6) * 0.1,) * 3, indexing="ij"), -1).reshape(-1, 3)
    singles = np.array([[2.0 + 0.8 * i, 0.25, 0.25] for i in range(4)])
    positions = np.concatenate([block, singles]).astype(np.float32)
    kept = meniscus.reconstruct(positions, spacing=0.1, threads=1)
    dropped = meniscus.reconstruct(positions, spacing=0.1, min_particles=2, threads=1)
    assert kept.stats["removed_strays"] == 0 and dropped.stats["removed_strays"] == 4
    assert len(dropped.triangles) < len(kept.triangles)
    assert dropped.vertices[:, 0].max() < 1.0  # the singles at x >= 2 are gone, the block stays
    with pytest.raises(ValueError, match="min_particles"):
        meniscus.reconstruct(positions, spacing=0.1, min_particles=-1)


def test_particle_box_ignores_the_particles_outside():
    block = np.stack(np.meshgrid(*(np.arange(6) * 0.1,) * 3, indexing="ij"), -1).reshape(-1, 3)
    wall = np.array([[1.5, 0.25, 0.25], [1.55, 0.3, 0.25]])  # stuck in a wall beyond x = 1
    positions = np.concatenate([block, wall]).astype(np.float32)
    inside = meniscus.reconstruct(block.astype(np.float32), spacing=0.1, threads=1)
    boxed = meniscus.reconstruct(positions, spacing=0.1, particle_box=(-1, -1, -1, 1, 1, 1), threads=1)
    assert boxed.stats["particles_outside_box"] == 2 and boxed.stats["particles"] == len(block)
    assert np.array_equal(boxed.vertices, inside.vertices) and np.array_equal(boxed.triangles, inside.triangles)
    with pytest.raises(ValueError, match="particle_box"):
        meniscus.reconstruct(positions, spacing=0.1, particle_box=(0, 0, 0, 1, 1))


def test_erode_moves_the_surface_inwards():
    positions = lattice_block((6, 6, 6))
    plain = meniscus.reconstruct(positions, spacing=0.1, threads=1)
    eroded = meniscus.reconstruct(positions, spacing=0.1, erode=0.02, threads=1)
    assert np.array_equal(plain.triangles, eroded.triangles)
    shift = np.einsum("ij,ij->i", eroded.vertices - plain.vertices, plain.normals)
    assert np.median(shift) == pytest.approx(-0.02, abs=0.004)


def test_clip_box_cuts_and_caps():
    block = np.stack(np.meshgrid(*(np.arange(8) * 0.1,) * 3, indexing="ij"), -1).reshape(-1, 3).astype(np.float32)
    box = (-1, -1, -1, 0.35, 1, 1)  # through the middle of the block along x
    cut = meniscus.reconstruct(block, spacing=0.1, clip_box=box, threads=1)
    assert cut.vertices[:, 0].max() <= np.float32(0.35) and cut.stats["cut_triangles"] > 0
    edges = np.sort(np.concatenate([cut.triangles[:, [0, 1]], cut.triangles[:, [1, 2]], cut.triangles[:, [2, 0]]]), 1)
    unique, uses = np.unique(edges, axis=0, return_counts=True)
    open_edges = unique[uses == 1]
    assert len(open_edges) > 0 and np.all(cut.vertices[open_edges.ravel(), 0] == np.float32(0.35))
    capped = meniscus.reconstruct(block, spacing=0.1, clip_box=box, clip_cap=True, threads=1)
    edges = np.sort(np.concatenate([capped.triangles[:, [0, 1]], capped.triangles[:, [1, 2]], capped.triangles[:, [2, 0]]]), 1)
    assert np.all(np.unique(edges, axis=0, return_counts=True)[1] == 2) and capped.stats["cap_open_edges"] == 0
    with pytest.raises(ValueError, match="clip_cap"):
        meniscus.reconstruct(block, spacing=0.1, clip_cap=True)


def test_decimate_keeps_fewer_triangles_mostly_of_the_same_vertices():
    block = np.stack(np.meshgrid(*(np.arange(10) * 0.1,) * 3, indexing="ij"), -1).reshape(-1, 3).astype(np.float32)
    full = meniscus.reconstruct(block, spacing=0.1, threads=1)
    simple = meniscus.reconstruct(block, spacing=0.1, decimate=0.02, threads=1)
    assert len(simple.triangles) < 0.5 * len(full.triangles)
    assert simple.stats["decimated_triangles"] == len(full.triangles) - len(simple.triangles)
    assert simple.stats["decimate_error"] <= 0.02 * 0.1
    # Most vertices are the full mesh's; the others met a neighbour halfway, between full vertices.
    kept = {tuple(v) for v in full.vertices.tolist()}
    same = np.array([tuple(v) in kept for v in simple.vertices.tolist()])
    assert same.mean() > 0.6
    moved = simple.vertices[~same]
    nearest = np.min(np.linalg.norm(moved[:, None, :] - full.vertices[None, :, :], axis=2), axis=1)
    assert np.all(nearest < 0.1)
    with pytest.raises(ValueError, match="decimate"):
        meniscus.reconstruct(block, spacing=0.1, decimate=3)
