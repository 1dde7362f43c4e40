"""meniscus.read_particles / read_mesh / write_mesh, Mesh from arrays, and the exceptions with
the CLI's messages."""
import re

import numpy as np
import pytest

import meniscus
from support import lattice_block


def cli_error(result):
    """The message the CLI printed after 'meniscus: error: '."""
    assert result.returncode != 0
    line = result.stderr.strip().splitlines()[-1]
    assert line.startswith("meniscus: error: "), result.stderr
    return line.removeprefix("meniscus: error: ")


def as_keywords(cli_message):
    """The CLI's message with its options spelled as the Python keywords of the same parameters
    (the table of parameters maps one onto the other): "--relax 5: …" → "relax=5: …"."""
    options = {p["option"]: p["key"] for p in meniscus.parameters() if p["option"]}
    message = re.sub(r"^(--[a-z-]+) (\S+?):", lambda m: f"{options[m.group(1)]}={m.group(2)}:", cli_message)
    return re.sub(r"--[a-z][a-z-]*", lambda m: options.get(m.group(0), m.group(0)), message)


def data_files(data):
    return sorted(p for p in data.rglob("*") if re.search(r"_(\d+)_(particles|points)\.", p.name))


def test_every_data_file_reads_with_the_count_in_its_name(data):
    files = data_files(data)
    assert len(files) >= 15
    for path in files:
        particles = meniscus.read_particles(path, columns=["x", "y", "z", "vx", "vy", "vz", "rho", "p", "mass"]
                                            if "IPART" in path.name else None)
        expected = int(re.search(r"_(\d+)_(particles|points)\.", path.name).group(1))
        if path.name.startswith("bunny_frame_14_7705"):
            expected = 7706  # the file holds one more than its name says (tests/data/README.md)
        positions, attributes = particles  # unpacks as a pair
        assert positions.shape == (expected, 3) and positions.dtype == np.float32, path
        assert not positions.flags.owndata and positions.base is not None
        for name, values in attributes.items():
            assert len(values) == expected, (path, name)
        assert particles.format and len(particles) == expected


def test_particle_attributes_keep_names_and_shapes(data):
    particles = meniscus.read_particles(data / "ply/dam_break_frame_9_6859_particles.ply")
    assert "velocity" in particles.attributes
    assert particles.attributes["velocity"].shape == (6859, 3)
    assert particles.format.startswith("ply")
    assert "6859 particles" in repr(particles)


def test_write_read_round_trip_keeps_arrays(tmp_path):
    mesh = meniscus.reconstruct(lattice_block((5, 5, 5)), {"velocity": np.tile([1.0, 2.0, 3.0], (125, 1))},
                                spacing=0.1, transfer=["velocity"])
    for extension in ("ply", "bgeo", "vtk"):
        path = tmp_path / f"mesh.{extension}"
        meniscus.write_mesh(path, mesh)
        back = meniscus.read_mesh(path)
        assert np.array_equal(back.triangles, mesh.triangles), extension
        assert np.array_equal(back.vertices, mesh.vertices), extension
        assert np.allclose(back.normals, mesh.normals, atol=1e-6), extension
        assert np.allclose(back.attributes["velocity"], [1, 2, 3], atol=1e-5), extension
        assert back.vertices.base is not None and not back.vertices.flags.owndata
    assert not list(tmp_path.glob("*.tmp*"))


def test_mesh_from_arrays_writes_and_reads_back(tmp_path):
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
    mesh = meniscus.Mesh(vertices, triangles, attributes={"temperature": np.array([1.0, 2.0, 3.0, 4.0])})
    assert mesh.vertices.dtype == np.float32 and mesh.triangles.dtype == np.uint32
    assert mesh.normals.shape == (0, 3) and mesh.stats == {}
    meniscus.write_mesh(tmp_path / "tet.ply", mesh)
    back = meniscus.read_mesh(tmp_path / "tet.ply")
    assert np.array_equal(back.triangles, triangles)
    assert np.array_equal(back.vertices, vertices.astype(np.float32))
    assert np.allclose(back.attributes["temperature"], [1, 2, 3, 4])
    # Arrays already in the right layout are taken as they are.
    v32 = vertices.astype(np.float32)
    assert meniscus.Mesh(v32, triangles).vertices is v32


def test_mesh_from_arrays_refuses_bad_shapes_and_indices(tmp_path):
    with pytest.raises(ValueError, match="vertices must be an n×3 array"):
        meniscus.Mesh(np.zeros((4, 2)), [[0, 1, 2]])
    with pytest.raises(ValueError, match="negative"):
        meniscus.Mesh(np.zeros((4, 3)), [[0, 1, -2]])
    with pytest.raises(TypeError, match="integer"):
        meniscus.Mesh(np.zeros((4, 3)), [[0.0, 1.0, 2.0]])
    bad = meniscus.Mesh(np.zeros((3, 3)), [[0, 1, 7]])
    with pytest.raises(ValueError, match="triangle 0 refers to vertex 7, but the mesh has 3 vertices"):
        meniscus.write_mesh(tmp_path / "bad.ply", bad)
    assert not (tmp_path / "bad.ply").exists()


def test_unknown_keyword_is_a_value_error_naming_it():
    with pytest.raises(ValueError, match="spacng") as error:
        meniscus.reconstruct(lattice_block((3, 3, 3)), spacng=0.1)
    assert type(error.value) is ValueError


def test_parameter_errors_have_the_clis_messages(cli, tmp_path):
    positions = lattice_block((4, 4, 4))
    np.save(tmp_path / "block.npy", positions)
    # The same message, each naming the parameter its own way: "relax=5: …" and "--relax 5: …".
    cases = [({"relax": 5}, ["--relax", "5"]),
             ({"spacing": 0.1, "r_inner": 0.2, "r_outer": 0.1}, ["--spacing", "0.1", "--r-inner", "0.2", "--r-outer", "0.1"]),
             ({"smoothness": 1.5}, ["--smoothness", "1.5"]),
             ({"steps_a": 20001}, ["--steps-a", "20001"]),
             ({"preset": "fast"}, ["--preset", "fast"])]
    for kwargs, options in cases:
        with pytest.raises(ValueError) as error:
            meniscus.reconstruct(positions, **kwargs)
        cli_message = cli_error(cli("surface", tmp_path / "block.npy", "-o", tmp_path / "out.ply", *options, check=False))
        assert str(error.value) == as_keywords(cli_message), kwargs
        assert str(error.value).startswith(next(iter(kwargs)) + "=") or "r_inner=" in str(error.value)
        assert "--" not in str(error.value), str(error.value)


def test_values_of_the_wrong_type():
    positions = lattice_block((3, 3, 3))
    with pytest.raises(ValueError, match="spacing"):
        meniscus.reconstruct(positions, spacing="wide")
    with pytest.raises(TypeError, match="spacing"):
        meniscus.reconstruct(positions, spacing=object())
    with pytest.raises(ValueError, match="steps_a"):
        meniscus.reconstruct(positions, steps_a=10**30)
    with pytest.raises(ValueError, match=r"positions must be an N×3 array, got shape \(27, 2\)"):
        meniscus.reconstruct(positions[:, :2])
    with pytest.raises(ValueError, match="particle attribute 'v' must have shape"):
        meniscus.reconstruct(positions, {"v": np.zeros(5)})
    with pytest.raises(ValueError, match="color"):  # a transfer attribute the particles lack
        meniscus.reconstruct(positions, spacing=0.1, transfer=["color"])
    # numpy scalars and None (= not given) are accepted
    mesh = meniscus.reconstruct(positions, spacing=np.float32(0.1), steps_a=np.int64(5), erode=None)
    assert mesh.params["steps_a"] == 5


def test_too_much_memory_is_a_memory_error_with_the_clis_message(cli, tmp_path):
    positions = lattice_block((4, 4, 4))
    np.save(tmp_path / "block.npy", positions)
    with pytest.raises(MemoryError) as error:
        meniscus.reconstruct(positions, spacing=0.1, voxel_size=0.0005, max_memory_gb=0.001)
    cli_message = cli_error(cli("surface", tmp_path / "block.npy", "-o", tmp_path / "out.ply", "--spacing", "0.1",
                                "--voxel-size", "0.0005", "--max-memory", "0.001", check=False))
    assert str(error.value) == as_keywords(cli_message)
    assert "max_memory_gb" in str(error.value)


def test_huge_input_arrays_are_refused_before_they_are_copied():
    # 10⁹ particles as a view of 24 bytes (a memory map or a broadcast view costs no memory until
    # it is copied): refused from their size alone, at once, with no copy made.
    import resource
    import time
    huge = np.broadcast_to(np.zeros(3), (10**9, 3))
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    start = time.monotonic()
    with pytest.raises(MemoryError, match=r"positions: copying it into the library's layout would take 12.0 GB"):
        meniscus.reconstruct(huge, max_memory_gb=1)
    with pytest.raises(MemoryError, match=r"particle attribute 'v'"):
        meniscus.reconstruct(lattice_block((3, 3, 3)), {"v": np.broadcast_to(np.zeros(1), (27, 10**8))}, max_memory_gb=1)
    assert time.monotonic() - start < 5
    assert (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss_before) * 1024 < 100e6


def test_positions_that_are_not_numbers_are_refused_by_name():
    block = lattice_block((3, 3, 3))
    for bad in (block > 0.1, block.astype(complex), block.astype(str), block.astype(object)):
        with pytest.raises(TypeError, match=f"positions must hold numbers \\(float or integer\\), got dtype {bad.dtype}"):
            meniscus.reconstruct(bad)
    with pytest.raises(TypeError, match="particle attribute 'v' must hold numbers"):
        meniscus.reconstruct(block, {"v": block.astype(str)})
    # Integers are numbers; booleans are welcome as an attribute (a flag).
    mesh = meniscus.reconstruct((block * 10).astype(np.int32), {"wet": block[:, 0] > 0.1}, spacing=1, transfer=["wet"])
    assert len(mesh.vertices) > 0


def test_truncated_file_is_a_format_error_with_the_byte_offset(cli, data, tmp_path):
    source = (data / "ply/fluid_250_particles.ply").read_bytes()
    truncated = tmp_path / "truncated.ply"
    truncated.write_bytes(source[: len(source) - 100])
    with pytest.raises(meniscus.FormatError) as error:
        meniscus.read_particles(truncated)
    assert isinstance(error.value, ValueError)
    assert "byte" in str(error.value) and str(truncated) in str(error.value)
    assert error.value.file == str(truncated) and error.value.location.startswith("byte ")
    expected = cli_error(cli("surface", truncated, "-o", tmp_path / "out.ply", check=False))
    assert str(error.value) == expected
    assert not (tmp_path / "out.ply").exists()


def test_missing_file_is_an_os_error_with_the_clis_message(cli, tmp_path):
    missing = tmp_path / "missing.ply"
    with pytest.raises(OSError) as error:
        meniscus.read_particles(missing)
    assert str(missing) in str(error.value)
    assert str(error.value) == cli_error(cli("surface", missing, "-o", tmp_path / "out.ply", check=False))
    with pytest.raises(OSError):
        meniscus.read_mesh(missing)
    with pytest.raises(OSError):
        meniscus.write_mesh(tmp_path / "no" / "such" / "dir" / "mesh.ply",
                            meniscus.Mesh(np.eye(3), [[0, 1, 2]]))


def test_nan_particles_are_refused_or_dropped(tmp_path):
    positions = lattice_block((3, 3, 3))
    positions[4] = np.nan
    path = tmp_path / "nan.npy"
    np.save(path, positions)
    with pytest.raises(meniscus.FormatError):
        meniscus.read_particles(path)
    particles = meniscus.read_particles(path, drop_invalid=True)
    assert len(particles) == 26 and particles.dropped_invalid == 1


def test_module_metadata():
    assert re.fullmatch(r"\d+\.\d+\.\d+.*", meniscus.__version__)
    assert meniscus.preset_names() == ["preview", "production", "droplets"]
    assert ".bgeo" in meniscus.particle_formats() or "bgeo" in " ".join(meniscus.particle_formats())
    assert meniscus.estimate_spacing(lattice_block((10, 10, 10))) == pytest.approx(0.1, rel=0.02)
