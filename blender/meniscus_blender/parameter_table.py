"""The parameters of `meniscus surface` as the program's table gives them (name, type, default,
range, unit, help): the panel's properties are made from these.

Made by blender/make_parameter_table.py from `meniscus info --parameters`; do not edit (a test
checks it against the program: run that script with --write after changing the table).
"""

PARAMETERS = {
    'spacing': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'unit': 'length', 'help': "particle separation d (Houdini's particle separation)", 'zero': 'estimated from the particles'},
    'voxel_size': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'unit': 'length', 'help': 'field resolution h (Marching Tiles: a tile period of 2h, the same sample density)', 'zero': 'd / (2·detail)'},
    'detail': {'type': 'number', 'default': 1.0, 'min': 0.0, 'min_open': True, 'max': 8.0, 'help': 'resolution multiplier: voxel size d / (2·detail); 2 ≈ 4× the triangles'},
    'r_inner': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'unit': 'length', 'help': 'vertices stay at least this far from their particle', 'zero': '0.5·r_outer'},
    'r_outer': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'unit': 'length', 'help': 'initial surface radius around each particle', 'zero': 'r_outer_factor·d'},
    'r_outer_factor': {'type': 'number', 'default': 1.0, 'min': 0.0, 'min_open': True, 'max': 4.0, 'unit': 'spacings', 'help': 'r_outer in spacings when r_outer is 0 (presets set it)'},
    'extract': {'type': 'choice', 'default': 'tiles', 'choices': ['tiles', 'cubes', 'tetrahedra'], 'help': 'extractor: tiles (Marching Tiles), cubes, tetrahedra'},
    'keep_voids': {'type': 'flag', 'default': False, 'help': 'keep interior voids smaller than (2 d)³ (removed by default)'},
    'field': {'type': 'choice', 'default': 'distance', 'choices': ['distance', 'metaball', 'sph', 'zhu-bridson', 'anisotropic'], 'help': 'field method: distance, metaball, sph, zhu-bridson, anisotropic (docs/fields.md)'},
    'iso': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'help': 'level of the field (metaball/sph/anisotropic: density threshold; zhu-bridson: particle radius)', 'zero': 'derived for the field method'},
    'kernel_radius': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'unit': 'length', 'help': 'support radius of the field kernels', 'zero': '2 d'},
    'rest_density': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'help': 'rest density ρ₀ of particles with a density but no mass (sph/anisotropic volumes d³·ρ₀/ρ)', 'zero': 'the median density of the frame'},
    'smooth_particles': {'type': 'number', 'default': -1.0, 'min': -1.0, 'min_open': False, 'max': 1.0, 'help': 'λ in [0, 1]: Laplacian smoothing of the particle positions before the field', 'zero': 'derived, 0.3 with --field anisotropic and 0 otherwise'},
    'steps_a': {'type': 'integer', 'default': 20, 'min': 0.0, 'min_open': False, 'max': 10000.0, 'unit': 'sweeps', 'help': 'constrained graph-Laplacian sweeps'},
    'steps_b': {'type': 'integer', 'default': 10, 'min': 0.0, 'min_open': False, 'max': 10000.0, 'unit': 'sweeps', 'help': 'constrained bilaplacian sweeps'},
    'steps_free': {'type': 'integer', 'default': 3, 'min': 0.0, 'min_open': False, 'max': 10000.0, 'unit': 'sweeps', 'help': 'unconstrained bilaplacian sweeps at the end: smoother normals, vertices up to about 0.1 d out of their shells (no particle outside); 0 keeps every vertex in its shell'},
    'relax': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'max': 1.0, 'help': 'relaxation ω of the A sweeps', 'zero': '1'},
    'relax_b': {'type': 'number', 'default': 1.0, 'min': 0.0, 'min_open': True, 'max': 1.0, 'help': 'largest damping of the B sweeps; each vertex takes at most its stable one'},
    'solver': {'type': 'choice', 'default': 'chebyshev', 'choices': ['chebyshev', 'jacobi'], 'help': 'sweeps: chebyshev (Jacobi, the A sweeps accelerated) or jacobi (plain); gauss-seidel is refused'},
    'rebuild_b': {'type': 'integer', 'default': 0, 'min': 0.0, 'min_open': False, 'max': 10000.0, 'unit': 'sweeps', 'help': 'rebuild the B operator every k sweeps', 'zero': 'once, after the A sweeps'},
    'velocity_weighted': {'type': 'flag', 'default': False, 'help': 'smooth fast (splashing) fluid less than calm fluid; needs a velocity attribute (v, vel, velocity)'},
    'velocity_reference': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'unit': 'speed', 'help': 'speed at which the smoothing reaches its minimum', 'zero': 'the 95th percentile of the particle speeds'},
    'velocity_min_weight': {'type': 'number', 'default': 0.2, 'min': 0.0, 'min_open': True, 'max': 1.0, 'help': 'smallest smoothing factor of fast fluid'},
    'erode': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'unit': 'length', 'help': 'move the finished surface inwards along its normals (warns above h/2, counts folded triangles)'},
    'min_particles': {'type': 'integer', 'default': 0, 'min': 0.0, 'min_open': False, 'max': 1000000000.0, 'unit': 'particles', 'help': 'drop surface components enclosing fewer particles than this (strays, particles stuck in a wall)', 'zero': 'keep every droplet'},
    'particle_box': {'type': 'numbers', 'default': [], 'help': 'xmin,ymin,zmin,xmax,ymax,zmax: surface only the particles inside this box'},
    'clip_box': {'type': 'numbers', 'default': [], 'help': 'xmin,ymin,zmin,xmax,ymax,zmax: cut the finished surface by this box, open along the cut'},
    'clip_cap': {'type': 'flag', 'default': False, 'help': "close the clip box's cut with the box's faces (the mesh stays watertight)"},
    'decimate': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'max': 1.0, 'unit': 'spacings', 'help': "simplify the mesh: the full surface's points held within this many spacings, the surfaces within 1.25x it anywhere (e.g. 0.02)", 'zero': 'keep every triangle'},
    'transfer': {'type': 'names', 'default': [], 'help': 'particle attributes to carry onto the vertices'},
    'transfer_radius': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'unit': 'length', 'help': 'radius of the transfer kernel (1 − (r/R)²)³; the nearest particle where none is inside', 'zero': '2 d'},
    'backend': {'type': 'choice', 'default': 'auto', 'choices': ['auto', 'cpu', 'cuda'], 'help': 'where to run: auto (cuda when a device is there), cpu, cuda'},
    'max_memory_gb': {'type': 'number', 'default': 0.0, 'min': 0.0, 'min_open': False, 'max': 1000000.0, 'unit': 'GB', 'help': "refuse work, and stop reading, past this much memory (the grant: RAM, cgroup, Slurm's --mem)", 'zero': '90 % of the memory granted'},
    'preset': {'type': 'choice', 'choices': ['preview', 'production', 'droplets'], 'control': True, 'help': 'preview (fast), production (the defaults) or droplets (keeps thin sheets and lone droplets)'},
    'smoothness': {'type': 'number', 'min': 0.0, 'min_open': False, 'max': 1.0, 'control': True, 'help': '0 (as extracted) .. 1 (twice the sweeps); 0.5 = the default schedule'},
}
