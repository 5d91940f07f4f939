"""The model stage's inputs: a network's arrays or a gmsh mesh, read once.

:meth:`ModelData.read` turns a scene's model section into data: a
:class:`~solver.model.generators.Network` (generated, given inline or read from
``model.file``) or a :class:`~solver.model.mesh.Mesh` (a .geo meshed or a .msh
read, on rank 0 of the ModelData's ``comm`` and broadcast).  The scene itself
stays configuration; errors name the scene key.  A run holds one ModelData and
passes it to the binding and the model build, so the file is read once; no
module keeps state between runs.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from solver.model import generators, mesh as mesh_io, transition
from solver.errors import SceneError


class ModelData:
    """The model data one run reads, each once: the network or mesh of a model
    section (the last ``KEEP`` sections, by their text and the working directory)
    and the transition band built on a mesh (:mod:`solver.model.transition`).
    ``comm``: meshes are read on its rank 0 and broadcast (None: this process
    reads its own).  ``keep`` False (one run of the command line): what was
    read is let go once the model is built (:meth:`built`)."""

    KEEP = 2

    def __init__(self, comm=None, keep: bool = True):
        self.comm = comm
        self.keep = keep
        self._sections: dict = {}
        self._transition: dict = {}

    def built(self):
        """The model is built from what this store read: unless it keeps (a
        store serving several runs), its meshes and bands are let go (rank 0's
        mesh is 128 MB of the 2.27 M-DOF bar's planning peak; the model keeps
        the arrays it uses)."""
        if not self.keep:
            self._sections.clear()
            self._transition.clear()

    def __len__(self) -> int:
        """Model sections read and kept."""
        return len(self._sections)

    def read(self, spec):
        """The data of the model section ``spec`` (NetworkModel or ContinuumModel)."""
        key = (repr(spec), Path.cwd())
        if key not in self._sections:
            data = _mesh(spec, self.comm) if spec.kind == "continuum" else _network(spec)
            while len(self._sections) >= self.KEEP:
                self._sections.pop(next(iter(self._sections)))
            self._sections[key] = data
        return self._sections[key]

    def transition(self, spec, mesh):
        """The transition band of ``spec`` on ``mesh``, built once (binding and the
        model build share it)."""
        key = (repr(spec), id(mesh))
        if key not in self._transition:
            self._transition.clear()
            self._transition[key] = (mesh, transition.build(spec, mesh))   # mesh kept: its id
        return self._transition[key][1]


def read(spec, comm=None):
    """The data of the model section ``spec``, read now (nothing kept)."""
    return ModelData(comm).read(spec)


def n_nodes(data) -> int:
    return int(data.points.shape[0]) if hasattr(data, "points") else int(data.mass.size)


def _mesh(spec, comm):
    try:
        return mesh_io.read(spec.mesh, comm=comm, parameters=spec.mesh_parameters,
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
