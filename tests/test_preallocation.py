"""Matrix preallocation from the blocks themselves (solver/partitions/assembly.py:
block_nonzeros): the block nonzeros per row in and off the diagonal block equal
a dense brute-force pattern of the same blocks (plus the diagonal), for bonds,
quadrilaterals and hexahedra mixed, nodes outside the matrix (-1), any row
range and row chunk; and a lattice operator of wave_bar_transition reserves no
block it does not fill (PETSc's own count of the assembled nonzeros)."""
import numpy as np
import pytest

from solver.partitions.assembly import block_nonzeros


def brute(block_sets, number, lo, hi, n_global):
    pattern = np.eye(n_global, dtype=bool)
    for conn, _ in block_sets:
        for c in number[conn]:
            c = c[c >= 0]
            pattern[np.ix_(c, c)] = True
    rows = pattern[lo:hi]
    d = rows[:, lo:hi].sum(axis=1)
    return d, rows.sum(axis=1) - d


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("lo,hi,chunk", [(0, 60, 32768), (13, 41, 5), (59, 60, 1), (20, 20, 7)])
def test_block_nonzeros_equal_the_dense_pattern(seed, lo, hi, chunk):
    rng = np.random.default_rng(seed)
    n_nodes, n_global = 90, 60
    number = np.full(n_nodes, -1)
    number[rng.permutation(n_nodes)[:n_global]] = np.arange(n_global)
    blocks = [(rng.integers(0, n_nodes, (m, k)), None)
              for m, k in ((40, 2), (15, 4), (6, 8), (0, 3))]
    got = block_nonzeros(blocks, number, lo, hi, n_global, chunk=chunk)
    want = brute(blocks, number, lo, hi, n_global)
    assert all(np.array_equal(g, w) for g, w in zip(got, want))
    assert got[0].dtype.kind == "i" and (got[0] >= 1).all()        # the diagonal at least


def test_no_blocks_reserve_the_diagonal_only():
    d, o = block_nonzeros([], np.arange(5), 1, 4, 5)
    assert d.tolist() == [1, 1, 1] and o.tolist() == [0, 0, 0]


def test_a_lattice_operator_reserves_only_what_it_fills(tmp_path):
    """bar3d's partitions: preallocated nonzeros == assembled ones (before,
    the node graph reserved the mesh cells' 27 blocks per row in the lattice
    operator's rows too, which fills 19)."""
    from conftest import built, raw_scene
    asm = built(raw_scene("bar3d"), tmp_path)
    for part in asm.parts:
        info = part.Kneg.getInfo()
        assert info["nz_allocated"] == info["nz_used"], (part.name, info)
