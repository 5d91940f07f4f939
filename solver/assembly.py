"""Assembly of element blocks into PETSc matrices with block size = dof.

Every operator is a sum of element blocks: mesh cells (K_e), lattice bonds
(k n n^T [[1, -1], [-1, 1]]), network springs ([[k, -k], [-k, k]], or [[k]]
to the ground).  A *block set* is ``(conn [n_el, k], Ke [n_el, k dof, k dof])``
with ``conn`` in node numbers; :func:`matrix` inserts them with
MatSetValuesBlocked, preallocated by PETSc's MATPREALLOCATOR, each rank only
its own rows (other rows are passed as -1, which PETSc skips).  Matrix types
that the AIJ family's preallocation does not cover (SELL, dense, ...) are
assembled as AIJ and converted with MatConvert, so every type holds the same
values.
"""
from __future__ import annotations

import numpy as np

from .petscutil import init

CHUNK = 8192          # elements per insertion call (bounds the temporaries)


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


def triplets(block_sets, dof: int):
    """COO of block sets (small operators: dense checks and references)."""
    r, c, v = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    for conn, Ke in block_sets:
        a, b, x = stiffness_triplets(Ke, conn, dof)
        r.append(a)
        c.append(b)
        v.append(x)
    return np.concatenate(r), np.concatenate(c), np.concatenate(v)


def _insert(A, block_sets, number, lo, hi, scale, P):
    add = P.InsertMode.ADD_VALUES
    for conn, Ke in block_sets:
        for s in range(0, len(conn), CHUNK):
            c = number[conn[s:s + CHUNK]]
            rows = np.where((c >= lo) & (c < hi), c, -1).astype(P.IntType)
            keep = (rows >= 0).any(axis=1)
            if not keep.any():
                continue
            ke = Ke[s:s + CHUNK][keep]
            A.setValuesBlockedRCV(rows[keep], c[keep].astype(P.IntType),
                                  ke * scale if scale != 1.0 else ke, add)


def default_type(dof: int, solved: bool = False) -> str:
    """BAIJ for vector DOFs (blocks of dof x dof: a third of AIJ's index traffic;
    MatMult 3.4x faster on the 862k-DOF hexahedral block), AIJ for scalars and
    for matrices a KSP solves (every PC takes AIJ)."""
    return "baij" if dof > 1 and not solved else "aij"


def matrix(block_sets, number, n_local: int, n_global: int, first: int, dof: int, comm,
           prefix: str, scale: float = 1.0, diagonal=None, mat_type: str = "aij"):
    """Square matrix (type ``mat_type`` unless the options say otherwise) over
    ``n_global`` nodes x ``dof``; this rank holds the
    ``n_local`` nodes from node ``first``.  ``block_sets``: a callable that
    yields (conn, Ke) block sets (called twice); ``number``: node -> matrix
    node number (-1: not in the matrix); ``diagonal``: values added to this
    rank's diagonal (e.g. the mass of K_eff)."""
    P = init()
    sizes = ((n_local * dof, n_global * dof), (n_local * dof, n_global * dof))
    A = P.Mat().create(comm=comm)
    A.setSizes(sizes, bsize=dof)
    A.setType(mat_type)
    A.setOptionsPrefix(prefix)
    A.setFromOptions()                           # -<prefix>mat_type overrides the default
    wanted = A.getType()
    if "aij" not in wanted:                      # SELL, dense, ...: build AIJ, convert
        A.destroy()
        A = P.Mat().create(comm=comm)
        A.setSizes(sizes, bsize=dof)
        A.setType(P.Mat.Type.AIJ)
    lo, hi = first, first + n_local
    pre = P.Mat().create(comm=comm)
    pre.setSizes(sizes, bsize=dof)
    pre.setType(P.Mat.Type.PREALLOCATOR)
    pre.setUp()
    _insert(pre, block_sets(), number, lo, hi, 1.0, P)
    own = np.arange(lo, hi, dtype=P.IntType)[:, None]
    eye = np.zeros((n_local, dof, dof))
    pre.setValuesBlockedRCV(own, own, eye, P.InsertMode.ADD_VALUES)   # every diagonal block
    pre.assemble()
    pre.preallocatorPreallocate(A, fill=True)
    pre.destroy()
    if diagonal is None:
        # axis-aligned bonds carry exact zeros in their k n n^T blocks: not stored
        A.setOption(P.Mat.Option.IGNORE_ZERO_ENTRIES, True)
    if A.getType().endswith("sbaij"):
        # symmetric storage keeps the upper triangle; the lower one is the same
        A.setOption(P.Mat.Option.IGNORE_LOWER_TRIANGULAR, True)
    _insert(A, block_sets(), number, lo, hi, scale, P)
    A.assemble()
    if diagonal is not None:
        d = A.createVecLeft()
        d.setArray(np.asarray(diagonal, dtype=float))
        A.setDiagonal(d, addv=P.InsertMode.ADD_VALUES)
        d.destroy()
    if A.getType() != wanted and "aij" not in wanted:
        A.convert(wanted)                       # in place
        A.setOptionsPrefix(prefix)
    return A


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


def assemble(Ke, conn, dim, n_nodes, comm, prefix, scale=1.0):
    """Sequential AIJ (block size dim) of ``n_nodes`` nodes from element matrices."""
    number = np.arange(n_nodes)
    return matrix(lambda: [(conn, Ke)], number, n_nodes, n_nodes, 0, dim, comm, prefix, scale)


def gershgorin(block_sets, held, mass_dofs, dof) -> float:
    """max_i sum_j |K_ij| s_i s_j over the blocks' entries (s = mass^-1/2; an
    infinite mass drops its DOF): an upper bound of omega_max^2 that never
    forms the matrix.  ``held``: node -> local index map source."""
    local = np.full(int(held.max()) + 2 if held.size else 1, -1, dtype=np.int64)
    local[held] = np.arange(held.size)
    s = 1.0 / np.sqrt(mass_dofs)
    radius = np.zeros(mass_dofs.size)
    for conn, Ke in block_sets:
        for a in range(0, len(conn), CHUNK):
            d = element_dofs(local[conn[a:a + CHUNK]], dof)            # [ne, nd]
            contrib = (np.abs(Ke[a:a + CHUNK]) * s[d][:, None, :]).sum(axis=2) * s[d]
            radius += np.bincount(d.ravel(), weights=contrib.ravel(), minlength=radius.size)
    return float(radius.max()) if radius.size else 0.0
