"""Meshes from gmsh: a .geo meshed through the gmsh API, or a .msh read by it.

``read(path, comm)`` reads on rank 0 of ``comm`` and broadcasts; scripts that
load a scene on every rank in step can ask for that with :func:`read_on`.
The command line instead loads the scene on rank 0 alone and broadcasts the
bound scene, so the other ranks never hold the mesh.  Scenes name physical
groups, not tags: ``Mesh.group(name)`` returns a group or raises a one-line
error that lists the groups the mesh has.  Cells of the top dimension are
kept per family (tri3, quad4, tet4, hex8); lower-dimensional groups keep their
node sets and facets (for Dirichlet conditions and tractions).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from solver.errors import SceneError

GMSH_TYPES = {1: ("line2", 1, 2), 2: ("tri3", 2, 3), 3: ("quad4", 2, 4), 4: ("tet4", 3, 4),
              5: ("hex8", 3, 8), 15: ("point", 0, 1)}


@dataclass(frozen=True)
class Group:
    """A physical group: its dimension, nodes (mesh indices) and cells per family."""

    name: str
    dim: int
    nodes: np.ndarray
    cells: dict = field(default_factory=dict)     # family -> connectivity (mesh node indices)
    cell_tags: dict = field(default_factory=dict)  # family -> gmsh element tags


@dataclass(frozen=True)
class Mesh:
    points: np.ndarray           # [n_nodes, dim] (shells: [n_nodes, 3])
    dim: int                     # topological dimension of the top cells
    groups: dict                 # name -> Group
    z_span: float = 0.0          # extent of the z coordinates (a curved surface is not plane)

    def group(self, name: str, where: str = "") -> Group:
        if name not in self.groups:
            from solver.scene.schema import shown
            have = ", ".join(f"{g} (dim {self.groups[g].dim})" for g in sorted(self.groups))
            raise SceneError(f"{where + ': ' if where else ''}mesh has no physical group "
                             f"{shown(name)}; it has: {have or 'none'}")
        return self.groups[name]


def _read_gmsh(path: str, dim: int | None, parameters: dict, gdim: int | None = None) -> Mesh:
    import gmsh
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        if parameters and path.endswith(".geo"):
            # gmsh.open resets the parser: prepend the definitions to a copy
            import tempfile
            head = "".join(f"{k} = {float(v)!r};\n" for k, v in parameters.items())
            with tempfile.NamedTemporaryFile("w", suffix=".geo", delete=False) as tmp:
                tmp.write(head + Path(path).read_text())
            try:
                gmsh.open(tmp.name)
            finally:
                Path(tmp.name).unlink()
        else:
            gmsh.open(path)
        if path.endswith(".geo"):
            gmsh.model.mesh.generate(dim or gmsh.model.getDimension())
        top = dim or gmsh.model.getDimension()
        tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(tags.size)
        xyz = coords.reshape(-1, 3)
        points = xyz[:, :gdim or top]
        z_span = float(np.ptp(xyz[:, 2])) if len(xyz) else 0.0
        groups = {}
        for gdim, gtag in gmsh.model.getPhysicalGroups():
            name = gmsh.model.getPhysicalName(gdim, gtag) or f"{gdim}:{gtag}"
            cells, etags = {}, {}
            for ent in gmsh.model.getEntitiesForPhysicalGroup(gdim, gtag):
                types, el_tags, node_tags = gmsh.model.mesh.getElements(gdim, ent)
                for t, et, nt in zip(types, el_tags, node_tags):
                    if t not in GMSH_TYPES:
                        raise SceneError(f"{path}: group {name!r} has gmsh element type {t}, "
                                         f"supported: {sorted(v[0] for v in GMSH_TYPES.values())}")
                    fam, _, k = GMSH_TYPES[t]
                    conn = index[nt.astype(np.int64)].reshape(-1, k)
                    cells[fam] = np.concatenate([cells[fam], conn]) if fam in cells else conn
                    etags[fam] = np.concatenate([etags[fam], et]) if fam in etags else et
            nodes = np.unique(np.concatenate([c.ravel() for c in cells.values()])) if cells \
                else np.zeros(0, dtype=np.int64)
            groups[name] = Group(name, gdim, nodes, cells, etags)
        return Mesh(points, top, groups, z_span)
    finally:
        gmsh.finalize()


# The communicator scenes read their meshes on (None: every process reads its own).
# Scripts that load scenes on every rank in step may set it (:func:`read_on`), so
# rank 0 meshes or reads the file once and broadcasts it.
READER = None


def read_on(comm):
    """Scenes loaded from now on read their meshes on rank 0 of ``comm`` (collective)."""
    global READER
    READER = comm if comm is not None and comm.size > 1 else None


def read(path: str, comm=None, dim: int | None = None, parameters: dict | None = None,
         gdim: int | None = None) -> Mesh:
    """Mesh ``path`` (.geo or .msh) on rank 0 of ``comm`` and broadcast it;
    ``parameters`` define .geo numbers before it is read; ``gdim``: the
    coordinates kept (default: as many as the top cells' dimension; 3 for
    shells)."""
    if not Path(path).is_file():
        raise SceneError(f"{path}: mesh file not found")
    from solver.collective import on_root

    def read_here():
        try:
            return _read_gmsh(str(path), dim, parameters or {}, gdim)
        except SceneError:
            raise
        except Exception as e:                                 # gmsh reports parse errors so
            raise SceneError(f"{path}: gmsh could not read it ({e})") from None
    return on_root(comm if comm is not None and comm.size > 1 else None, read_here)
