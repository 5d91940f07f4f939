"""Element blocks of a mesh's cell groups, computed where the model builds them.

:class:`CellStiffness` gives K_e of a family's cells when asked (never all stored),
:func:`group_matrices` the stiffness and lumped masses of every cell family of a group,
:func:`kept` a subset of a block set and :func:`nodal` sums per-element nodal values.
The partitions assemble these blocks (:mod:`solver.partitions.assembly`).
"""
from __future__ import annotations

import numpy as np

from solver.errors import SceneError
from solver.model.elements import FAMILIES, BadElement, lumped_mass, stiffness


class CellStiffness:
    """K_e of a family's cells, computed when asked and never all stored:
    ``ke[idx]`` returns [len(idx), nd, nd] for element indices, a slice or a mask."""

    def __init__(self, family, points, conn, material):
        self.family, self.points, self.conn, self.material = family, points, conn, material

    def __len__(self) -> int:
        return len(self.conn)

    def __getitem__(self, idx) -> np.ndarray:
        return stiffness(self.family, self.points[self.conn[idx]], self.material)

    def subset(self, mask) -> "CellStiffness":
        return CellStiffness(self.family, self.points, self.conn[mask], self.material)


def kept(conn, Ke, keep):
    """(conn, Ke) of the elements ``keep`` (a mask) of a block set, whether Ke
    is an array or computed when asked (``subset``)."""
    if keep.all():
        return conn, Ke
    return conn[keep], (Ke.subset(keep) if hasattr(Ke, "subset") else Ke[keep])


def nodal(values: np.ndarray, conn: np.ndarray, n_nodes: int) -> np.ndarray:
    """Sum per-element nodal values [n_el, n_nodes_el] into nodes [n_nodes]."""
    return np.bincount(conn.ravel(), weights=values.ravel(), minlength=n_nodes)


def group_matrices(mesh, name: str, material, where: str = "", only=None):
    """Element stiffness (computed when asked) and lumped masses of every cell
    family of group ``name`` (or of the cells ``only``, family -> conn, taken
    from it): list of (family, conn, CellStiffness, me).  An inverted or
    degenerate cell is reported with its group and gmsh element tag."""
    group = mesh.group(name, where)
    out = []
    for fam_name, conn in (group.cells if only is None else only).items():
        fam = FAMILIES.get(fam_name)
        if fam is None or fam.dim != mesh.dim:
            raise SceneError(f"{where + ': ' if where else ''}group {name!r} has {fam_name} cells; "
                             f"a {mesh.dim}D body needs {[f for f, v in FAMILIES.items() if v.dim == mesh.dim]}")
        X = mesh.points[conn]
        try:
            me = lumped_mass(fam, X, material)        # also checks every Jacobian
            out.append((fam, conn, CellStiffness(fam, mesh.points, conn, material), me))
        except BadElement as e:
            at = np.flatnonzero((group.cells[fam_name] == conn[e.index]).all(axis=1))[0]
            tag = int(group.cell_tags[fam_name][at])
            raise SceneError(f"{where + ': ' if where else ''}group {name!r}: gmsh element {tag} "
                             f"({fam_name}) {str(e).split(' is ', 1)[1]}") from None
    return out
