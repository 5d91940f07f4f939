"""The model stage's inputs: a network's arrays or a gmsh mesh, read once.

``read(spec)`` turns a scene's model section into data: a
:class:`~solver.model.generators.Network` (generated, given inline or read from
``model.file``) or a :class:`~solver.model.mesh.Mesh` (a .geo meshed or a .msh
read, on rank 0 of ``mesh.READER`` and broadcast).  The scene itself stays
configuration; errors name the scene key.  Results are kept per model section
so binding the scene and building the model read the file once.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from solver.model import generators
from solver.errors import SceneError

_KEEP = 2
_cache: dict = {}


def read(spec):
    """The data of the model section ``spec`` (NetworkModel or ContinuumModel)."""
    key = (repr(spec), Path.cwd())
    if key not in _cache:
        data = _mesh(spec) if spec.kind == "continuum" else _network(spec)
        while len(_cache) >= _KEEP:
            _cache.pop(next(iter(_cache)))
        _cache[key] = data
    return _cache[key]


def n_nodes(data) -> int:
    return int(data.points.shape[0]) if hasattr(data, "points") else int(data.mass.size)


def _mesh(spec):
    from solver.model import mesh
    try:
        return mesh.read(spec.mesh, comm=mesh.READER, parameters=spec.mesh_parameters,
                         gdim=3 if spec.material.kind == "shell" else None)
    except SceneError as e:
        raise SceneError(f"model.mesh: {e}") from None


def _network(spec):
    if spec.file is not None:
        if not Path(spec.file).is_file():
            raise SceneError(f"model.file: {spec.file}: file not found")
        where = (f"model.file {spec.file}: mass", f"model.file {spec.file}: spring")
        try:
            net = generators.from_file(spec.file)
        except (ValueError, OSError, KeyError) as e:
            raise SceneError(f"model.file: {e}") from None
    elif spec.generator is not None:
        net, where = generators.generate(spec.generator), ("model.generator",) * 2
    else:
        net = generators.Network(
            mass=np.asarray(spec.masses, dtype=float),
            spring_i=np.array([sp.i for sp in spec.springs], dtype=np.int64),
            spring_j=np.array([sp.j for sp in spec.springs], dtype=np.int64),
            stiffness=np.array([sp.stiffness for sp in spec.springs], dtype=float),
            groups={"nodes": (0, len(spec.masses))})
        where = ("model.masses", "model.springs")
    try:
        net.validate(*where)
    except ValueError as e:
        raise SceneError(str(e)) from None
    return net
