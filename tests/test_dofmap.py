"""The DOF map: nodes with different DOF counts through assembly, partitions
and the exchange (tests/mixed_dofs.py), against dense and exact solutions."""
import numpy as np
import pytest
from mpi4py import MPI

from conftest import raw_scene
from mixed_dofs import K2, U2, mixed, run
from solver.model import arrays
from solver.model.dofmap import DofMap, ranges
from solver.partitions.assembly import matrix, triplets
from solver.model.binding import from_dict


def test_numbering_of_mixed_counts():
    dm = DofMap([1, 3, 2, 1])
    assert dm.block is None and dm.n_dofs == 7
    assert dm.dofs([2, 0]).tolist() == [4, 5, 0]
    assert dm.starts([2, 0, 1]).tolist() == [0, 2, 3]
    node, comp = dm.node_of([0, 1, 3, 4, 6])
    assert node.tolist() == [0, 1, 1, 2, 3] and comp.tolist() == [0, 0, 2, 0, 0]
    # numbering that puts node 3 first, then 1; nodes 0 and 2 not numbered
    first = dm.numbered(np.array([-1, 1, -1, 0]))
    assert first.tolist() == [-1, 1, -1, 0]
    assert dm.element_dofs(np.array([[3, 1]]), first).tolist() == [[0, 1, 2, 3]]
    with pytest.raises(ValueError, match="differ in their nodes' DOF counts"):
        dm.element_dofs(np.array([[0, 1], [1, 0]]), dm.offsets[:-1])
    assert ranges([5, 0], [2, 3]).tolist() == [5, 6, 0, 1, 2]
    assert DofMap.uniform(4, 3).block == 3


def test_mixed_matrix_equals_dense_sum_of_blocks():
    rng = np.random.default_rng(1)
    dm = DofMap([2, 1, 3, 2, 1, 2])
    sets = []
    for conn in ([[0, 1], [3, 4]], [[2, 5]], [[1, 2, 3]]):
        conn = np.array(conn)
        nd = int(dm.counts[conn[0]].sum())
        sets.append((conn, rng.standard_normal((len(conn), nd, nd))))
    number = np.array([3, 0, 5, 1, 4, 2])          # a permuted numbering of all nodes
    A = matrix(lambda: sets, number, 6, 6, 0, dm, MPI.COMM_SELF, "mixtest_", scale=2.0)
    r, c, v = triplets(sets, dm)
    K = np.zeros((dm.n_dofs, dm.n_dofs))
    np.add.at(K, (r, c), 2.0 * v)
    first = dm.numbered(number)
    perm = np.concatenate([first[n] + np.arange(dm.counts[n]) for n in range(6)])
    dense = np.zeros_like(K)
    dense[np.ix_(perm, perm)] = K
    assert A.getType() == "seqaij" and A.getSize() == (dm.n_dofs, dm.n_dofs)
    assert np.allclose(A.getValues(range(dm.n_dofs), range(dm.n_dofs)), dense, rtol=0, atol=1e-14)
    A.destroy()


def test_mixed_chain_follows_plain_chain_and_exact_oscillators():
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 1.0
    scene = from_dict(raw)
    plain = arrays.build(scene)
    n = scene.n_system_steps
    h_plain = run(scene, plain, MPI.COMM_SELF, n)
    h_mixed = run(scene, mixed(plain), MPI.COMM_SELF, n)
    for node in range(6):
        a, b = h_plain[(node, 0)], h_mixed[(node, 0)]
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()
    steps = {p.name: p.ratio * scene.time.dt for p in scene.partitions}
    for node in (1, 3, 5):
        h = steps["fem"] if node in scene.partitions[0].nodes else steps["dem"]
        per = round(scene.system_dt / h)
        omega = np.arccos(1 - 0.5 * h * h * K2)
        exact = U2 * np.cos(omega * per * np.arange(n + 1))
        assert np.abs(h_mixed[(node, 1)] - exact).max() < 1e-9 * U2


def test_a_uniform_map_holds_no_array_over_the_nodes():
    """DofMap.uniform answers as the map of an explicit count array does
    (counts, offsets read by index arrays of any shape and by slices, starts,
    dofs, node_of, numbered), pickles in a few bytes and holds no array as
    long as the nodes."""
    import pickle
    import numpy as np
    from solver.model.dofmap import DofMap
    n = 1000
    a, b = DofMap.uniform(n, 3), DofMap(np.full(n, 3))
    nodes = np.array([[0, n - 1], [400, 2]])
    assert (a.n_nodes, a.n_dofs, a.largest, a.block) == (b.n_nodes, b.n_dofs, b.largest, b.block)
    assert np.array_equal(a.offsets[nodes], b.offsets[nodes]) and a.offsets[-1] == b.offsets[-1]
    assert np.array_equal(a.offsets[:-1], b.offsets[:-1]) and np.array_equal(a.counts[nodes], b.counts[nodes])
    for f in ("starts", "dofs"):
        assert np.array_equal(getattr(a, f)([5, 1, 7]), getattr(b, f)([5, 1, 7]))
    d = np.array([0, 5, 3 * n - 1])
    assert all(np.array_equal(x, y) for x, y in zip(a.node_of(d), b.node_of(d)))
    num = np.where(np.arange(n) % 3 == 0, -1, np.arange(n))
    assert np.array_equal(a.numbered(num), b.numbered(num))
    back = pickle.loads(pickle.dumps(a))
    assert len(pickle.dumps(a)) < 200 and back.n_dofs == 3 * n and back.counts.strides == (0,)
    assert a.counts.base is not None and a.counts.strides == (0,)
