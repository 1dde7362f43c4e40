"""meniscus.Reconstructor and the input protocols: made once, called per frame, each call
reconstruct()'s mesh bit for bit; positions and attributes read in place from C-ordered float32
(NumPy, memory maps, memoryviews, __array_interface__, host __dlpack__), converted once
otherwise; bad input and device arrays refused by name; a second call while one runs refused."""
import threading

import numpy as np
import pytest

import meniscus
from support import lattice_block

SEQUENCE = ["sph_dambreak/ParticleData_Fluid_0020.bgeo", "sph_dambreak/ParticleData_Fluid_0030.bgeo"]


def jittered(n, spacing=0.1, seed=1, origin=(0, 0, 0)):
    rng = np.random.default_rng(seed)
    x = lattice_block(n, spacing) + np.asarray(origin, np.float32)
    return (x + rng.uniform(-0.2 * spacing, 0.2 * spacing, x.shape)).astype(np.float32)


def assert_same_mesh(a, b):
    assert a.vertices.tobytes() == b.vertices.tobytes()
    assert np.array_equal(a.triangles, b.triangles)
    assert a.normals.tobytes() == b.normals.tobytes()
    assert sorted(a.attributes) == sorted(b.attributes)
    for name in a.attributes:
        assert a.attributes[name].tobytes() == b.attributes[name].tobytes(), name


def test_every_frame_is_reconstructs_mesh_as_count_and_extent_change(data):
    frames = [jittered((6, 6, 6)), jittered((14, 7, 6), seed=2, origin=(3, 0, 0)),
              jittered((3, 3, 3), 0.05, seed=3, origin=(-40, 7, 2)), jittered((9, 9, 4), seed=4)]
    frames = [(x, {"velocity": np.cross(x, [0, 0, 1]).astype(np.float32)}) for x in frames]
    for name in SEQUENCE:  # the real sequence, spacing estimated on each frame
        p = meniscus.read_particles(data / name)
        frames.append((p.positions, p.attributes))
    surface = meniscus.Reconstructor(transfer=["velocity"], threads=2)
    for positions, attributes in frames:
        once = meniscus.reconstruct(positions, attributes, transfer=["velocity"], threads=2)
        looped = surface(positions, attributes)
        assert_same_mesh(once, looped)
        assert looped.params["spacing"] == once.params["spacing"]
        assert looped.stats["genus"] == once.stats["genus"]
        assert len(looped.triangles) > 100
    assert surface.frames == len(frames)
    assert surface.params == {"transfer": ["velocity"], "threads": 2}


class ArrayInterfaceOnly:
    """An object offering only __array_interface__ (as a simulator's own array type might)."""

    def __init__(self, array):
        self._array = array
        self.__array_interface__ = array.__array_interface__


class DLPackOnly:
    """An object offering only DLPack (as a PyTorch CPU tensor or a JAX array does)."""

    def __init__(self, array):
        self._array = array

    def __dlpack__(self, stream=None):
        return self._array.__dlpack__()

    def __dlpack_device__(self):
        return self._array.__dlpack_device__()


def test_every_input_protocol_layout_and_dtype_gives_the_same_mesh(tmp_path):
    x = jittered((8, 7, 5))
    density = (1000 + np.arange(len(x)) % 7).astype(np.float32)
    reference = meniscus.reconstruct(x, {"density": density}, spacing=0.1, transfer=["density"])
    assert len(reference.triangles) > 1000
    n = len(x)
    wide = np.zeros((n, 7), np.float32)
    wide[:, 2:5] = x
    mapped = np.lib.format.open_memmap(tmp_path / "x.npy", mode="w+", dtype=np.float32, shape=x.shape)
    mapped[:] = x
    mapped.flush()
    read_only = x.copy()
    read_only.setflags(write=False)
    in_place = {
        "float32": x, "read-only": read_only, "memory map": np.load(tmp_path / "x.npy", mmap_mode="r"),
        "memoryview": memoryview(x), "__array_interface__": ArrayInterfaceOnly(x), "__dlpack__": DLPackOnly(x),
    }
    copied = {
        "float64": x.astype(np.float64), "strided": wide[:, 2:5], "Fortran order": np.asfortranarray(x),
        "negative strides": x[::-1].copy()[::-1], "float64 strided": np.asfortranarray(x.astype(np.float64)),
        "big-endian": x.astype(">f4"), "float64 __dlpack__": DLPackOnly(x.astype(np.float64)),
    }
    surface = meniscus.Reconstructor(spacing=0.1, transfer=["density"])
    for label, positions in list(in_place.items()) + list(copied.items()):
        for call in (surface, lambda p, a: meniscus.reconstruct(p, a, spacing=0.1, transfer=["density"])):
            mesh = call(positions, {"density": density})
            assert_same_mesh(mesh, reference)
            read = mesh.stats["input"]
            if label in in_place:
                assert read == {"bytes_read_in_place": 16 * n, "bytes_copied": 0}, label
            else:
                assert read == {"bytes_read_in_place": 4 * n, "bytes_copied": 12 * n}, label
    # Attributes the same way: float64 and strided columns converted, a float32 column in place.
    both = np.stack([density, density], axis=1)
    for values, in_place_bytes in ((density.astype(np.float64), 12 * n), (both[:, 1], 12 * n),
                                   (DLPackOnly(density), 16 * n)):
        mesh = surface(x, {"density": values})
        assert_same_mesh(mesh, reference)
        assert mesh.stats["input"]["bytes_read_in_place"] == in_place_bytes
    # Integer attributes come back as integers (converted once into floats, as the library holds them).
    ids = np.arange(n, dtype=np.int64)
    mesh = meniscus.reconstruct(x, {"id": ids}, spacing=0.1)
    assert mesh.stats["input"] == {"bytes_read_in_place": 12 * n, "bytes_copied": 4 * n}


def test_the_arrays_handed_back_are_the_results_own_without_a_copy():
    mesh = meniscus.Reconstructor(spacing=0.1)(jittered((6, 6, 6)))
    for array in (mesh.vertices, mesh.triangles, mesh.normals):
        assert not array.flags.owndata and array.base is not None
    # And they go on by DLPack without a copy (what torch.from_dlpack does with them).
    assert np.shares_memory(np.from_dlpack(mesh.vertices), mesh.vertices)


def test_bad_input_is_an_exception_naming_the_argument():
    surface = meniscus.Reconstructor(spacing=0.1)
    x = jittered((5, 5, 5))
    with pytest.raises(ValueError, match=r"positions must be an N×3 array, got shape \(125, 2\)"):
        surface(x[:, :2])
    with pytest.raises(TypeError, match=r"positions must hold numbers .*complex"):
        surface(x.astype(np.complex64))
    with pytest.raises(TypeError, match=r"positions must hold numbers .*bool"):
        surface(x > 0)
    with pytest.raises(TypeError, match="positions must hold numbers .*got dtype <U9"):
        surface("particles")
    bad = x.copy()
    bad[17, 1] = np.inf
    with pytest.raises(ValueError, match=r"positions\[17\] is not finite"):
        surface(bad)
    with pytest.raises(ValueError, match=r"positions\[3\] is not finite"):
        surface(np.where(np.arange(len(x))[:, None] == 3, np.nan, x.astype(np.float64)))
    with pytest.raises(ValueError, match=r"particle attribute 'density' must have shape \(125,\)"):
        surface(x, {"density": np.ones(124, np.float32)})
    with pytest.raises(TypeError, match="particle attribute 'name' must hold numbers"):
        surface(x, {"name": np.array(["a"] * len(x))})
    with pytest.raises(ValueError, match="transfer: the particles have no attribute 'velocity'"):
        meniscus.Reconstructor(spacing=0.1, transfer=["velocity"])(x)
    # Parameters are checked when it is made, before any frame.
    with pytest.raises(ValueError, match="steps_a=20001"):
        meniscus.Reconstructor(steps_a=20001)
    with pytest.raises(ValueError, match="no_such_option"):
        meniscus.Reconstructor(no_such_option=1)
    # It surfaces again after every refusal.
    assert len(surface(x).triangles) > 100


class OnTheDevice:
    """A CUDA array as DLPack describes one (device type 2) or as CuPy/Numba/Warp describe one."""

    def __init__(self, dlpack=True):
        if dlpack:
            self.__dlpack_device__ = lambda: (2, 0)
            self.__dlpack__ = lambda stream=None: None
        else:
            self.__cuda_array_interface__ = {"shape": (10, 3), "typestr": "<f4", "data": (0, False), "version": 3}


@pytest.mark.parametrize("dlpack", [True, False])
def test_an_array_on_a_cuda_device_is_refused_by_name(dlpack):
    with pytest.raises(TypeError, match="positions lives on a (CUDA )?device"):
        meniscus.Reconstructor(spacing=0.1)(OnTheDevice(dlpack))
    with pytest.raises(TypeError, match="particle attribute 'v' lives on a (CUDA )?device"):
        meniscus.reconstruct(jittered((4, 4, 4)), {"v": OnTheDevice(dlpack)}, spacing=0.1)


def test_a_call_while_another_runs_is_refused_and_the_running_one_finishes():
    x = jittered((6, 6, 6))
    surface = meniscus.Reconstructor(spacing=0.1)
    alone = surface(x)
    inside, done = threading.Event(), threading.Event()
    refused, results = [], []

    def waiting(stage, fraction):  # the first call waits in its progress until the second has come back
        inside.set()
        done.wait(timeout=60)

    def first():
        results.append(surface(x, progress=waiting))

    def second():
        inside.wait(timeout=60)
        try:
            surface(x)
        except RuntimeError as error:
            refused.append(str(error))
        done.set()

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert refused and "one Reconstructor per thread" in refused[0]
    assert_same_mesh(results[0], alone)

    # From its own progress callback too: the error cancels the running call, as any raise there does.
    def reentrant(stage, fraction):
        surface(x)

    with pytest.raises(RuntimeError, match="surfacing a frame already"):
        surface(x, progress=reentrant)
    assert_same_mesh(surface(x), alone)
    assert surface.frames == 3
