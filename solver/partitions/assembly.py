"""Assembly of element blocks into PETSc matrices over a DOF map.

Every operator is a sum of element blocks: mesh cells (K_e), lattice bonds
(k n n^T [[1, -1], [-1, 1]]), network springs ([[k, -k], [-k, k]], or [[k]]
to the ground).  A *block set* is ``(conn [n_el, k], Ke [n_el, nd, nd])``
with ``conn`` in node numbers and nd the DOFs of an element's nodes
(:mod:`solver.model.dofmap`); :func:`matrix` inserts them with
MatSetValuesBlocked when every node has the same DOF count (MatSetValues
otherwise), each rank only its own rows (other rows are passed as -1, which
PETSc skips).  AIJ and BAIJ are preallocated from the blocks' own pattern
(:func:`block_nonzeros`: exactly the blocks a matrix holds, so a lattice's
operator does not reserve the mesh cells' wider rows); other types, and
scalar rows of mixed DOF counts, by PETSc's MATPREALLOCATOR.  Matrix types
that the AIJ family's preallocation does not cover (SELL, dense, ...) are
assembled as AIJ and converted with MatConvert, so every type holds the same
values.
"""
from __future__ import annotations

import numpy as np

from solver.petscutil import init
from solver.errors import SceneError
from solver.model.graph import incidence

CHUNK = 2048          # elements per insertion call (bounds the temporaries)


def stiffness_triplets(Ke: np.ndarray, conn: np.ndarray, dofmap):
    """COO (rows, cols, values) of element matrices Ke [n_el, nd, nd] over the
    model DOFs of ``dofmap``."""
    dofs = dofmap.element_dofs(conn, dofmap.offsets[:-1])
    nd = dofs.shape[1]
    rows = np.repeat(dofs, nd, axis=1).ravel()
    cols = np.tile(dofs, (1, nd)).ravel()
    return rows, cols, Ke.reshape(len(Ke), -1).ravel()


def triplets(block_sets, dofmap):
    """COO of block sets (small operators: dense checks and references)."""
    r, c, v = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    for conn, Ke in block_sets:
        if not len(conn):
            continue
        a, b, x = stiffness_triplets(Ke[:len(conn)], conn, dofmap)
        r.append(a)
        c.append(b)
        v.append(x)
    return np.concatenate(r), np.concatenate(c), np.concatenate(v)


def _insert(A, block_sets, index, lo, hi, scale, P, blocked=True):
    """Add block sets, each element's rows lo..hi only.  ``index(conn)`` gives the
    matrix indices of elements ``conn``: node blocks (``blocked``, inserted with
    MatSetValuesBlocked) or scalar DOFs (MatSetValues)."""
    add = P.InsertMode.ADD_VALUES
    setter = A.setValuesBlockedRCV if blocked else A.setValuesRCV
    for conn, Ke in block_sets:
        for s in range(0, len(conn), CHUNK):
            c = index(conn[s:s + CHUNK])
            rows = np.where((c >= lo) & (c < hi), c, -1).astype(P.IntType)
            keep = (rows >= 0).any(axis=1)
            if not keep.any():
                continue
            ke = Ke[np.arange(s, s + len(c))[keep]]          # only the elements of my rows
            setter(rows[keep], c[keep].astype(P.IntType), ke * scale if scale != 1.0 else ke, add)


def default_type(dof, solved: bool = False) -> str:
    """BAIJ for vector DOFs (blocks of dof x dof: a third of AIJ's index traffic;
    MatMult 3.4x faster on the 862k-DOF hexahedral block), AIJ for scalars, for
    mixed DOF counts (``dof`` None) and for matrices a KSP solves (every PC
    takes AIJ)."""
    return "baij" if dof is not None and dof > 1 and not solved else "aij"


def matrix(block_sets, number, n_local: int, n_global: int, first: int, dofmap, comm,
           prefix: str, scale: float = 1.0, diagonal=None, mat_type: str = "aij"):
    """Square matrix (type ``mat_type`` unless the options say otherwise) over
    the ``n_global`` nodes of the node numbering ``number`` (node -> matrix node,
    -1: not in the matrix), each with the DOFs of ``dofmap`` (a
    :class:`~solver.model.dofmap.DofMap`, or a DOF count for all nodes); this
    rank holds the ``n_local`` nodes from node ``first``.  ``block_sets``: a
    callable that yields (conn, Ke) block sets (called twice); ``diagonal``:
    values added to this rank's diagonal (e.g. the mass of K_eff).  Nodes
    with equal DOF counts are inserted by blocks
    (block size = the count); mixed counts make a scalar AIJ matrix."""
    if isinstance(dofmap, (int, np.integer)):
        return _matrix(block_sets, number, n_local, n_global, first, int(dofmap), comm, prefix,
                       scale, diagonal, mat_type)
    if dofmap.block is not None:
        return _matrix(block_sets, number, n_local, n_global, first, dofmap.block, comm, prefix,
                       scale, diagonal, mat_type)
    return _scalar_matrix(block_sets, number, n_local, first, dofmap, comm, prefix, scale,
                          diagonal, mat_type)


def _create(comm, sizes, bsize, mat_type, prefix):
    """A Mat of ``mat_type`` (or the type the options give); types outside the
    AIJ family are created as AIJ, to be converted after assembly."""
    P = init()
    A = P.Mat().create(comm=comm)
    A.setSizes(sizes, bsize=bsize)
    A.setType(mat_type)
    A.setOptionsPrefix(prefix)
    A.setFromOptions()                           # -<prefix>mat_type overrides the default
    wanted = A.getType()
    if "aij" not in wanted:                      # SELL, dense, ...: build AIJ, convert
        A.destroy()
        A = P.Mat().create(comm=comm)
        A.setSizes(sizes, bsize=bsize)
        A.setType(P.Mat.Type.AIJ)
    return A, wanted


def _preallocate(A, comm, sizes, bsize, insert, own, P):
    """Preallocate ``A`` with PETSc's MATPREALLOCATOR from ``insert(pre)`` plus
    every owned diagonal entry ``own``."""
    pre = P.Mat().create(comm=comm)
    pre.setSizes(sizes, bsize=bsize)
    pre.setType(P.Mat.Type.PREALLOCATOR)
    pre.setUp()
    insert(pre)
    eye = np.zeros((own.size, bsize, bsize))
    if bsize > 1:
        pre.setValuesBlockedRCV(own[:, None], own[:, None], eye, P.InsertMode.ADD_VALUES)
    else:
        pre.setValuesRCV(own[:, None], own[:, None], eye, P.InsertMode.ADD_VALUES)
    pre.assemble()
    pre.preallocatorPreallocate(A, fill=True)
    pre.destroy()


def _finish(A, insert, diagonal, wanted, prefix, P):
    if diagonal is None:
        # axis-aligned bonds carry exact zeros in their k n n^T blocks: not stored
        A.setOption(P.Mat.Option.IGNORE_ZERO_ENTRIES, True)
    if A.getType().endswith("sbaij"):
        # symmetric storage keeps the upper triangle; the lower one is the same
        A.setOption(P.Mat.Option.IGNORE_LOWER_TRIANGULAR, True)
    insert(A)
    A.assemble()
    if diagonal is not None:
        d = A.createVecLeft()
        d.setArray(np.asarray(diagonal, dtype=float))
        A.setDiagonal(d, addv=P.InsertMode.ADD_VALUES)
        d.destroy()
    if "aij" not in wanted:
        A.convert(wanted)                       # in place
        A.setOptionsPrefix(prefix)
    return A


def _matrix(block_sets, number, n_local, n_global, first, dof, comm, prefix, scale, diagonal,
            mat_type):
    """Every node with ``dof`` DOFs: blocks of dof x dof."""
    P = init()
    sizes = ((n_local * dof, n_global * dof), (n_local * dof, n_global * dof))
    A, wanted = _create(comm, sizes, dof, mat_type, prefix)
    lo, hi = first, first + n_local
    kind = A.getType()
    if "sbaij" not in kind and ("baij" in kind or "aij" in kind):
        d_nnz, o_nnz = block_nonzeros(block_sets(), number, lo, hi, n_global)
        if "baij" not in kind:                   # AIJ counts scalar rows
            d_nnz, o_nnz = np.repeat(d_nnz * dof, dof), np.repeat(o_nnz * dof, dof)
        A.setPreallocationNNZ((d_nnz.astype(P.IntType), o_nnz.astype(P.IntType)))
    else:
        _preallocate(A, comm, sizes, dof,
                     lambda M: _insert(M, block_sets(), number.__getitem__, lo, hi, 1.0, P),
                     np.arange(lo, hi, dtype=P.IntType), P)
    return _finish(A, lambda M: _insert(M, block_sets(), number.__getitem__, lo, hi, scale, P),
                   diagonal, wanted, prefix, P)


def _scalar_matrix(block_sets, number, n_local, first, dofmap, comm, prefix, scale, diagonal,
                   mat_type):
    """Nodes with differing DOF counts: scalar rows, preallocated by PETSc."""
    P = init()
    dof_first = dofmap.numbered(number)
    numbered = number >= 0
    lo = int(dofmap.counts[numbered & (number < first)].sum())
    hi = lo + int(dofmap.counts[numbered & (number >= first) & (number < first + n_local)].sum())
    n_global = int(dofmap.counts[numbered].sum())
    sizes = ((hi - lo, n_global), (hi - lo, n_global))
    A, wanted = _create(comm, sizes, 1, "aij" if "baij" in mat_type else mat_type, prefix)
    if "baij" in A.getType():
        kind = A.getType()
        A.destroy()
        raise SceneError(f"-{prefix}mat_type {kind}: nodes with differing DOF counts need a "
                         "scalar matrix type (aij, sell, dense)")

    def insert(M, s):
        _insert(M, block_sets(), lambda conn: dofmap.element_dofs(conn, dof_first), lo, hi, s, P,
                blocked=False)
    _preallocate(A, comm, sizes, 1, lambda M: insert(M, 1.0), np.arange(lo, hi, dtype=P.IntType), P)
    return _finish(A, lambda M: insert(M, scale), diagonal, wanted, prefix, P)


def block_nonzeros(block_sets, number, lo, hi, n_global, chunk: int = 32768):
    """(d_nnz, o_nnz): block nonzeros of block rows lo..hi-1 in and off the
    diagonal block, from the pattern of the block sets themselves (``number``:
    node -> matrix node, -1: not in the matrix) plus every row's diagonal.
    Only the elements with a row here count; the pattern is the sparse product
    R^T C of their incidence matrices (R: the rows here), taken ``chunk`` rows
    at a time: the incidence matrices grow with the rank's elements (about
    45 MB for 200,000 hexahedral rows, against 390 MB of BAIJ values), the
    product's temporaries do not; no element matrix is computed."""
    from scipy.sparse import eye   # lazy: scipy loads only where it is used
    n = hi - lo
    conns = []
    for conn, _ in block_sets:
        for s in range(0, len(conn), 65536):
            c = number[np.asarray(conn[s:s + 65536])]
            mine = ((c >= lo) & (c < hi)).any(axis=1)
            if mine.any():
                conns.append(c[mine])
    d, o = np.zeros(n, np.int64), np.zeros(n, np.int64)
    C = incidence(conns, n_global)
    del conns
    if C is not None:
        Rt = C[:, lo:hi].T.tocsr()               # the elements of each row here
    for a in range(0, n, chunk):
        b = min(a + chunk, n)
        pattern = eye(b - a, n_global, k=lo + a, dtype=bool, format="csr")
        if C is not None:
            pattern = pattern + Rt[a:b] @ C
        counts = np.diff(pattern.indptr)
        inside = (pattern.indices >= lo) & (pattern.indices < hi)
        d[a:b] = np.bincount(np.repeat(np.arange(b - a), counts), weights=inside, minlength=b - a)
        o[a:b] = counts - d[a:b]
    return d, o


def assemble(Ke, conn, dim, n_nodes, comm, prefix, scale=1.0):
    """Sequential AIJ (block size dim) of ``n_nodes`` nodes from element matrices."""
    number = np.arange(n_nodes)
    return matrix(lambda: [(conn, Ke)], number, n_nodes, n_nodes, 0, dim, comm, prefix, scale)


def rows_of(op, rows, comm):
    """(S, out): the matrix of rows ``rows`` (global indices, this rank's) of the
    assembled ``op``, with op's column layout, so that S.mult(x, out) gives those
    rows of op x (ghost columns refreshed by PETSc whatever the rank layout),
    and its out Vec.  Collective on ``comm``: a rank with no row takes part."""
    P = init()
    got = [op.getRow(int(r)) for r in rows]
    S = P.Mat().createAIJ(((len(got), None), op.getSizes()[1]), comm=comm)
    S.setPreallocationNNZ(max((cols.size for cols, _ in got), default=1))
    first = S.getOwnershipRange()[0]
    for i, (cols, vals) in enumerate(got):
        S.setValues([first + i], cols, vals)
    S.assemble()
    return S, S.createVecLeft()
