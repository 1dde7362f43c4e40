"""meniscus — fluid-simulation particles to a smooth, watertight triangle mesh.

    import numpy as np, meniscus
    particles = meniscus.read_particles("fluid_0023.bgeo")      # or (positions, attributes)
    mesh = meniscus.reconstruct(particles, preset="production", smoothness=0.7,
                                transfer=["velocity"])
    mesh.vertices, mesh.triangles, mesh.normals, mesh.attributes["velocity"], mesh.stats
    meniscus.write_mesh("fluid_0023.ply", mesh)

The keyword parameters of :func:`reconstruct` are the CLI's options with ``_`` for ``-``
(``spacing``, ``voxel_size``, ``r_inner``, ``r_outer``, ``extract``, ``steps_a``, ``steps_b``,
``steps_free``, ``relax``, ``relax_b``, ``solver``, ``rebuild_b``, ``erode``, ``min_particles``, ``particle_box``,
``clip_box``, ``clip_cap``, ``decimate``, ``transfer``,
``transfer_radius``, ``keep_voids``, ``threads``, ``max_memory_gb``) plus the artist controls
``preset``, ``smoothness`` and ``detail``; they go through the same code as ``--config`` files,
so a name means the same everywhere.

Errors are raised with the library's messages (what the CLI prints after ``meniscus: error:``,
with parameters named as keywords: ``steps_a=20001: must be a whole number from 0 to 10000``):

=================================  ============================================================
``ValueError``                     a bad parameter (unknown name, out of range, wrong type of
                                   value), a bad array shape, or particles that cannot be
                                   surfaced (fewer than 2, all at one point, a stray far
                                   away); ``TypeError`` for a value of an unusable Python type
:class:`FormatError` (ValueError)  a file that cannot be parsed; names the file, the byte offset
                                   or line and what was expected (``.file``, ``.location``)
``OSError``                        a file that cannot be opened, read or written
``MemoryError``                    a job or a file that would need more memory than allowed
                                   (``max_memory_gb``), refused before allocating
=================================  ============================================================

Arrays returned by :func:`reconstruct`, :func:`read_mesh` and :func:`read_particles` share memory
with the C++ result (their ``.base`` owns it): nothing is copied. Input arrays are read in place
when they are C-ordered float32 (NumPy, memory maps, the buffer protocol, ``__array_interface__``,
``__dlpack__`` on the host), converted once otherwise. The GIL is released while the library
reads, writes or reconstructs, so other Python threads keep running.
"""

import json as _json

import numpy as _np

from . import _core
from ._core import FormatError

__version__ = _core.__version__

__all__ = [
    "FormatError",
    "Mesh",
    "Particles",
    "Reconstructor",
    "estimate_spacing",
    "mesh_formats",
    "parameters",
    "particle_formats",
    "preset_names",
    "read_mesh",
    "read_particles",
    "reconstruct",
    "temporal_smoothing",
    "write_mesh",
    "__version__",
]


class Mesh:
    """An indexed triangle mesh.

    ``vertices``   V×3 float32 positions
    ``triangles``  T×3 uint32 vertex indices, counter-clockwise seen from outside the fluid
    ``normals``    V×3 float32 unit normals (may be empty (0, 3) for a mesh built by hand)
    ``attributes`` dict name → (V,) or (V, k) array (``color``, ``velocity`` …)
    ``stats``      dict: counts, seconds per stage, peak memory, warnings (the ``--stats`` JSON);
                   empty unless the mesh came from :func:`reconstruct`
    ``params``     dict: every parameter actually used (``stats["parameters"]``)

    ``Mesh(vertices, triangles, normals=None, attributes=None)`` builds one from arrays (for
    :func:`write_mesh`); arrays already of the right dtype and layout are not copied.
    """

    __slots__ = ("vertices", "triangles", "normals", "attributes", "stats", "params")

    def __init__(self, vertices, triangles, normals=None, attributes=None, stats=None, params=None):
        self.vertices = _triples(vertices, _np.float32, "vertices")
        self.triangles = _triples(triangles, _np.uint32, "triangles")
        self.normals = _triples(() if normals is None else normals, _np.float32, "normals")
        self.attributes = dict(attributes or {})
        self.stats = dict(stats or {})
        self.params = dict(params or self.stats.get("parameters", {}))

    @classmethod
    def _from_core(cls, arrays, stats=None):
        mesh = cls.__new__(cls)
        mesh.vertices = arrays["vertices"]
        mesh.triangles = arrays["triangles"]
        mesh.normals = arrays["normals"]
        mesh.attributes = arrays["attributes"]
        mesh.stats = stats or {}
        mesh.params = mesh.stats.get("parameters", {})
        return mesh

    def __repr__(self):
        names = ", ".join(self.attributes) or "no attributes"
        return f"<meniscus.Mesh {len(self.vertices)} vertices, {len(self.triangles)} triangles, {names}>"


def _triples(values, dtype, what):
    """An n×3 C-contiguous array of `dtype` (no copy when it already is one)."""
    array = _np.asarray(values)
    if array.size == 0:
        return _np.zeros((0, 3), dtype)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{what} must be an n×3 array, got shape {array.shape}")
    if dtype == _np.uint32:
        if array.dtype.kind not in "iu":
            raise TypeError(f"{what} must be integer vertex indices, got {array.dtype}")
        if array.dtype.kind == "i" and array.min() < 0:
            raise ValueError(f"{what} must not hold negative vertex indices")
    return _np.ascontiguousarray(array, dtype=dtype)


class Particles:
    """Particles read from a file: ``positions`` (N×3 float32), ``attributes`` (dict name →
    (N,) or (N, k) array; integer attributes as int32), ``format`` (e.g. ``"ply (binary little
    endian)"``) and ``dropped_invalid`` (particles dropped for NaN/Inf coordinates).

    Unpacks as ``positions, attributes = meniscus.read_particles(path)`` and can be passed to
    :func:`reconstruct` as is.
    """

    __slots__ = ("positions", "attributes", "format", "dropped_invalid")

    def __init__(self, positions, attributes=None, format="", dropped_invalid=0):
        self.positions = positions
        self.attributes = dict(attributes or {})
        self.format = format
        self.dropped_invalid = dropped_invalid

    def __iter__(self):
        return iter((self.positions, self.attributes))

    def __len__(self):
        return len(self.positions)

    def __repr__(self):
        names = ", ".join(self.attributes) or "no attributes"
        return f"<meniscus.Particles {len(self.positions)} particles ({self.format}), {names}>"


def _input_arrays(positions, attributes, progress):
    if isinstance(positions, Particles):
        if attributes is None:
            attributes = positions.attributes
        positions = positions.positions
    if progress is not None and not callable(progress):
        raise TypeError("progress must be callable(stage, fraction)")
    return positions, attributes


def _mesh_of(arrays):
    stats = _json.loads(arrays["stats"])
    stats["input"] = {"bytes_read_in_place": arrays["bytes_read_in_place"],
                      "bytes_copied": arrays["bytes_copied"]}
    return Mesh._from_core(arrays, stats)


def reconstruct(positions, attributes=None, *, progress=None, **params):
    """Surfaces particles into a watertight triangle mesh.

    ``positions``  N×3 array of float32/float64 (or integers) in any layout: a NumPy array, or
                   any object with the buffer protocol, ``__array_interface__`` or a host
                   ``__dlpack__`` (a PyTorch CPU tensor); C-ordered float32 is read in place,
                   anything else converted once. A :class:`Particles` too, whose attributes are
                   used when ``attributes`` is None
    ``attributes`` dict name → (N,) or (N, k) array (read the same way); those named in
                   ``transfer`` are carried onto the mesh vertices
    ``progress``   optional ``callable(stage: str, fraction: float)``, called at the start (0.0)
                   and end (1.0) of every stage; raising in it cancels the reconstruction and the
                   exception propagates. Ctrl-C is honoured at stage boundaries too.
    ``**params``   the CLI's options with ``_`` (see the module doc); a value of None is ignored.

    Returns a :class:`Mesh` with ``stats`` and ``params`` (``stats["input"]``: the input bytes
    read in place and copied). Raises ValueError for a bad parameter or input (the message names
    it: ``positions[7] is not finite``), TypeError for an array of the wrong kind (strings, or
    one on a CUDA device), MemoryError when the job would not fit (``max_memory_gb``).
    For a frame after frame, :class:`Reconstructor` does once what this does every call.
    """
    positions, attributes = _input_arrays(positions, attributes, progress)
    return _mesh_of(_core.reconstruct(positions, attributes, params, progress))


class Reconstructor:
    """:func:`reconstruct` made once and called per frame, as a simulator's loop calls it::

        surface = meniscus.Reconstructor(spacing=0.025, preset="production")
        for step in range(frames):
            simulate(positions)                      # the simulator's own arrays …
            mesh = surface(positions)                # … read in place (float32 N×3)

    Each call returns what ``reconstruct(positions, attributes, **params)`` returns, bit for bit.
    Made once: the parameters are checked (ValueError here, before any frame), the threads and
    memory granted are asked of the system, and the buffers that converted inputs (float64,
    strided) go through are kept from call to call. Every frame's derived parameters (spacing when
    not given, radii, grid) are its own, so a frame's mesh never depends on an earlier one.

    One call at a time: a call while another runs (from a second thread, or from the running
    call's ``progress``) raises RuntimeError; make one Reconstructor per thread.
    """

    __slots__ = ("_core", "_params")

    def __init__(self, **params):
        self._params = dict(params)
        self._core = _core.Reconstructor(params)

    def __call__(self, positions, attributes=None, *, progress=None):
        positions, attributes = _input_arrays(positions, attributes, progress)
        return _mesh_of(self._core(positions, attributes, progress))

    @property
    def params(self):
        """The parameters as given (each mesh's ``params`` has them resolved for its frame)."""
        return dict(self._params)

    @property
    def frames(self):
        """Frames surfaced so far."""
        return self._core.frames

    def __repr__(self):
        given = ", ".join(f"{k}={v!r}" for k, v in self._params.items())
        return f"<meniscus.Reconstructor({given}), {self.frames} frames>"


def read_particles(path, columns=None, drop_invalid=False, max_memory_gb=0):
    """Reads a particle file (any format of ``meniscus info``: .bgeo/.bgeo.sc, .vtk, .vtu/.vtp,
    .ply, .csv/.txt, .npy, .xyz; gzip by content) into a :class:`Particles`.

    ``columns``       names for headerless text columns, e.g. ``["x", "y", "z", "vx", "vy", "vz"]``
    ``drop_invalid``  drop particles with NaN/Inf coordinates instead of raising FormatError
    ``max_memory_gb`` the most memory the read may hold (the file, inflated, and the particles);
                      0: 90 % of the memory granted. Past it: MemoryError, before it is taken
    """
    positions, attributes, fmt, dropped = _core.read_particles(
        str(path), list(columns or []), bool(drop_invalid), float(max_memory_gb))
    return Particles(positions, attributes, fmt, dropped)


def read_mesh(path):
    """Reads a triangle mesh (.ply, .obj, .vtk, .bgeo) into a :class:`Mesh`."""
    return Mesh._from_core(_core.read_mesh(str(path)))


def write_mesh(path, mesh):
    """Writes a :class:`Mesh` (or any object with ``vertices``, ``triangles`` and optionally
    ``normals`` and ``attributes``) by extension: .ply, .bgeo, .obj, .vtk, .usda. The file is
    written under a temporary name and renamed when complete."""
    normals = getattr(mesh, "normals", None)
    if normals is not None and _np.size(normals) == 0:
        normals = None
    _core.write_mesh(str(path), mesh.vertices, mesh.triangles, normals,
                     getattr(mesh, "attributes", None) or None)


def estimate_spacing(positions):
    """The particle spacing meniscus uses when ``spacing`` is not given (see the README)."""
    if isinstance(positions, Particles):
        positions = positions.positions
    return _core.estimate_spacing(positions)


def temporal_smoothing(previous, current, next, *, weight=0.25, limit=None):
    """Frame t's particle positions smoothed in time with frames t - 1 and t + 1, as ``meniscus
    surface`` does for a sequence (docs/method.md "temporal"): each position x becomes
    ``(1 - 2 weight) x + weight (x_prev + x_next)``, the same particle found in each frame by its id,
    the shift at most ``limit`` (default: a quarter of the spacing estimated on ``current``, half of
    r_inner with the default radii). Each frame is a :class:`Particles` with an ``id`` attribute or a
    ``(positions, ids)`` pair. Returns ``(positions, report)``: float32 N×3 in ``current``'s order,
    and a dict (``applied``, ``skipped`` — why not, ``matched``, ``clamped``, ``mean_shift``,
    ``max_shift``). Frames whose ids are missing, not whole numbers below 2**24 or repeated come back
    as they were, with the reason."""
    def pair(frame, name):
        if isinstance(frame, Particles):
            if "id" not in frame.attributes:
                raise ValueError(f"{name} has no 'id' attribute: the particles are matched by it")
            return frame.positions, frame.attributes["id"]
        positions, ids = frame
        return positions, ids
    (p0, i0), (p1, i1), (p2, i2) = pair(previous, "previous"), pair(current, "current"), pair(next, "next")
    if limit is None:
        limit = 0.25 * estimate_spacing(p1)
    return _core.temporal_smoothing(p0, i0, p1, i1, p2, i2, float(weight), float(limit))


def parameters():
    """The table of parameters, a list of dicts (``key``, ``type``, ``default``, ``min``, ``max``,
    ``accepts``, ``help`` …): the keywords of :func:`reconstruct` with their ranges, the same table
    the CLI's options and ``--config`` files come from."""
    return _json.loads(_core.parameter_table())


def preset_names():
    """The named presets, e.g. ``["preview", "production", "droplets"]``."""
    return list(_core.preset_names())


def particle_formats():
    """The particle file extensions understood."""
    return list(_core.particle_formats())


def mesh_formats():
    """The mesh file extensions written."""
    return list(_core.mesh_formats())
