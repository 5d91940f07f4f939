"""Meshes from gmsh: a .geo meshed through the gmsh API, or a .msh read by it.

``read(path, comm)`` reads on rank 0 of ``comm`` and broadcasts; scripts that
load a scene on every rank in step can ask for that with a
``ModelData(comm)`` (:mod:`solver.model.data`) passed to the binding.
The command line instead loads the scene on rank 0 alone and broadcasts the
bound scene, so the other ranks never hold the mesh.  Scenes name physical
groups, not tags: ``Mesh.group(name)`` returns a group or raises a one-line
error that lists the groups the mesh has.  Cells of the top dimension are
kept per family (tri3, quad4, tet4, hex8); lower-dimensional groups keep their
node sets and facets (for Dirichlet conditions and tractions).

Reading checks what the element kernels assume (docs/theory/index.md, "Meshes"): every node
has finite coordinates; only first-order elements (point, line2, tri3, quad4,
tet4, hex8) are accepted, any other gmsh type is refused by name (tri6, prism6,
...); a cell listed twice in a group (the same nodes: an MSH 2 file writes an
element once per physical group it belongs to) is kept once, and the removed
duplicates are reported in ``Mesh.notes``; a top-dimensional entity (a plane
surface in 2D, a volume in 3D) whose cells are all inverted (a curve loop that
runs clockwise) is reoriented, also with a note.
"""
from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from solver.errors import SceneError
from solver.scene.schema import shown
from solver.model.elements import CELLS
from solver.collective import on_root
from solver.memory import release

# names of the gmsh element types that are refused (gmsh's own name for the others)
OTHER_TYPES = {6: "prism6", 7: "pyramid5", 8: "line3", 9: "tri6", 10: "quad9", 11: "tet10",
               12: "hex27", 13: "prism18", 14: "pyramid14", 16: "quad8", 17: "hex20",
               18: "prism15", 19: "pyramid13", 20: "tri9", 21: "tri10", 26: "line4",
               29: "tet20", 36: "quad16", 92: "hex64"}
ORDER_WORDS = {2: "second-order", 3: "third-order", 4: "fourth-order", 5: "fifth-order"}


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
    notes: tuple = ()            # what reading changed (duplicates removed, entities reoriented)

    def group(self, name: str, where: str = "") -> Group:
        if name not in self.groups:
            have = ", ".join(f"{g} (dim {self.groups[g].dim})" for g in sorted(self.groups))
            raise SceneError(f"{where + ': ' if where else ''}mesh has no physical group "
                             f"{shown(name)}; it has: {have or 'none'}")
        return self.groups[name]


def _unsupported(path, name, t) -> SceneError:
    """The refusal of gmsh element type ``t`` in group ``name``, in words."""
    import gmsh  # lazy: gmsh loads only where a mesh is read
    try:
        gname, _, order, _, _, _ = gmsh.model.mesh.getElementProperties(int(t))
    except Exception:                                          # noqa: BLE001 (unknown to gmsh)
        gname, order = f"type {t}", 1
    what = OTHER_TYPES.get(int(t), f"{gname!r}")
    if order > 1:
        what = f"{ORDER_WORDS.get(order, f'order-{order}')} {what}"
    hint = "; mesh with Mesh.ElementOrder = 1" if order > 1 else ""
    return SceneError(f"{path}: group {name!r}: {what} elements are not supported (gmsh type "
                      f"{t}{hint}); supported: "
                      f"{', '.join(sorted(f.name for f in CELLS.by_gmsh.values()))}")


def _orientation(family, X):
    """Jacobian determinant at the centre of each cell [n_el] (X [n_el, k, dim])."""
    _, dN = family.shape(np.array([family.centre]))
    return np.linalg.det(np.einsum("ai,eaj->eij", dN[0], X))


def _entity_cells(path, name, gdim, ent, index, xyz, top, flat, notes):
    """{family: (conn, tags)} of one entity's elements; an entity of the top
    dimension whose cells are all inverted is reoriented (noted)."""
    import gmsh  # lazy: gmsh loads only where a mesh is read
    out = {}
    types, el_tags, node_tags = gmsh.model.mesh.getElements(gdim, ent)
    for t, et, nt in zip(types, el_tags, node_tags):
        family = CELLS.by_gmsh.get(int(t))
        if family is None:
            raise _unsupported(path, name, t)
        fam = family.name
        conn = index[nt.astype(np.int64)].reshape(-1, family.n_nodes)
        if flat and gdim == top and family.mirror is not None and len(conn):
            det = _orientation(family, xyz[conn][:, :, :top])
            if np.all(det < 0):
                conn = conn[:, list(family.mirror)]
                why = ("surface", "its curve loop runs clockwise") if top == 2 else \
                    ("volume", "every cell is inside out")
                notes.append(f"{path}: {why[0]} {ent} ({len(conn)} {fam} cells) has negative "
                             f"orientation ({why[1]}): reoriented")
        out[fam] = (np.concatenate([out[fam][0], conn]), np.concatenate([out[fam][1], et])) \
            if fam in out else (conn, et)
    return out


def _unique_cells(path, name, fam, conn, tags, notes):
    """The cells of a group with repeats (the same nodes in any order) removed."""
    _, first = np.unique(np.sort(conn, axis=1), axis=0, return_index=True)
    if len(first) == len(conn):
        return conn, tags
    keep = np.sort(first)
    dropped = np.setdiff1d(np.arange(len(conn)), keep)
    notes.append(f"{path}: group {name!r}: removed {len(dropped)} duplicated {fam} cells (the "
                 f"same nodes listed again, e.g. gmsh element {int(tags[dropped[0]])}); "
                 f"{len(keep)} remain")
    return conn[keep], tags[keep]


def _read_gmsh(path: str, dim: int | None, parameters: dict, gdim: int | None = None) -> Mesh:
    import gmsh  # lazy: gmsh loads only where a mesh is read
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        if parameters and path.endswith(".geo"):
            # gmsh.open resets the parser: prepend the definitions to a copy
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
        if not tags.size:
            raise SceneError(f"{path}: the mesh has no nodes")
        xyz = coords.reshape(-1, 3)
        bad = np.flatnonzero(~np.isfinite(xyz).all(axis=1))
        if bad.size:
            raise SceneError(f"{path}: node {int(tags[bad[0]])} has non-finite coordinates "
                             f"{xyz[bad[0]].tolist()} ({bad.size} such nodes)")
        index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(tags.size)
        points = xyz[:, :gdim or top]
        z_span = float(np.ptp(xyz[:, 2])) if len(xyz) else 0.0
        # cells are oriented where the coordinates kept span the cells' dimension
        flat = (gdim or top) == top
        groups, notes, entities = {}, [], {}
        # the top dimension first: a refused element type is named on the body's cells
        physical = gmsh.model.getPhysicalGroups()
        for pdim, ptag in sorted(physical, key=lambda g: -g[0]):
            name = gmsh.model.getPhysicalName(pdim, ptag) or f"{pdim}:{ptag}"
            cells, etags = {}, {}
            for ent in gmsh.model.getEntitiesForPhysicalGroup(pdim, ptag):
                if (pdim, ent) not in entities:
                    entities[(pdim, ent)] = _entity_cells(path, name, pdim, ent, index, xyz,
                                                          top, flat, notes)
                for fam, (conn, et) in entities[(pdim, ent)].items():
                    cells[fam] = np.concatenate([cells[fam], conn]) if fam in cells else conn
                    etags[fam] = np.concatenate([etags[fam], et]) if fam in etags else et
            for fam in cells:
                cells[fam], etags[fam] = _unique_cells(path, name, fam, cells[fam], etags[fam],
                                                       notes)
            nodes = np.unique(np.concatenate([c.ravel() for c in cells.values()])) if cells \
                else np.zeros(0, dtype=np.int64)
            groups[name] = Group(name, pdim, nodes, cells, etags)
        order = [gmsh.model.getPhysicalName(d, t) or f"{d}:{t}" for d, t in physical]
        return Mesh(points, top, {g: groups[g] for g in order}, z_span, tuple(notes))
    finally:
        gmsh.finalize()
        release()            # gmsh's freed heap: about half of rank 0's memory after meshing



def read(path: str, comm=None, dim: int | None = None, parameters: dict | None = None,
         gdim: int | None = None) -> Mesh:
    """Mesh ``path`` (.geo or .msh) on rank 0 of ``comm`` and broadcast it;
    ``parameters`` define .geo numbers before it is read; ``gdim``: the
    coordinates kept (default: as many as the top cells' dimension; 3 for
    shells)."""
    if not Path(path).is_file():
        raise SceneError(f"{path}: mesh file not found")

    def read_here():
        try:
            return _read_gmsh(str(path), dim, parameters or {}, gdim)
        except SceneError:
            raise
        except Exception as e:                                 # gmsh reports parse errors so
            raise SceneError(f"{path}: gmsh could not read it ({e})") from None
    return on_root(comm if comm is not None and comm.size > 1 else None, read_here)
