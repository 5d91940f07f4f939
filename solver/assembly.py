"""Global assembly of element matrices into PETSc AIJ with block size = dim.

Element DOFs are node-major, so element DOF ``a*dim + c`` is global DOF
``conn[e, a]*dim + c``; duplicates are summed once in CSR form.
"""
from __future__ import annotations

import numpy as np

from .petscutil import aij


def element_dofs(conn: np.ndarray, dim: int) -> np.ndarray:
    """Global DOFs of every element [n_el, n_nodes*dim]."""
    return (conn[:, :, None] * dim + np.arange(dim)).reshape(len(conn), -1)


def stiffness_triplets(Ke: np.ndarray, conn: np.ndarray, dim: int):
    """COO (rows, cols, values) of element matrices Ke [n_el, nd, nd]."""
    dofs = element_dofs(conn, dim)
    nd = dofs.shape[1]
    rows = np.repeat(dofs, nd, axis=1).ravel()
    cols = np.tile(dofs, (1, nd)).ravel()
    return rows, cols, Ke.reshape(len(Ke), -1).ravel()


def assemble(Ke, conn, dim, n_nodes, comm, prefix, scale=1.0):
    """AIJ matrix (block size dim) of n_nodes*dim rows from element matrices."""
    rows, cols, vals = stiffness_triplets(Ke, conn, dim)
    return aij(rows, cols, vals, n_nodes * dim, comm, prefix, scale=scale, bs=dim)


def nodal(values: np.ndarray, conn: np.ndarray, n_nodes: int) -> np.ndarray:
    """Sum per-element nodal values [n_el, n_nodes_el] into nodes [n_nodes]."""
    return np.bincount(conn.ravel(), weights=values.ravel(), minlength=n_nodes)


def group_matrices(mesh, name: str, material, where: str = ""):
    """Element stiffness and lumped masses of every cell family of group ``name``:
    list of (family, conn, Ke, me).  An inverted or degenerate cell is reported
    with its group and gmsh element tag."""
    from .elements import FAMILIES, BadElement, lumped_mass, stiffness
    from .errors import SceneError
    group = mesh.group(name, where)
    out = []
    for fam_name, conn in group.cells.items():
        fam = FAMILIES.get(fam_name)
        if fam is None or fam.dim != mesh.dim:
            raise SceneError(f"{where + ': ' if where else ''}group {name!r} has {fam_name} cells; "
                             f"a {mesh.dim}D body needs {[f for f, v in FAMILIES.items() if v.dim == mesh.dim]}")
        X = mesh.points[conn]
        try:
            out.append((fam, conn, stiffness(fam, X, material), lumped_mass(fam, X, material)))
        except BadElement as e:
            tag = int(group.cell_tags[fam_name][e.index])
            raise SceneError(f"{where + ': ' if where else ''}group {name!r}: gmsh element {tag} "
                             f"({fam_name}) {str(e).split(' is ', 1)[1]}") from None
    return out
