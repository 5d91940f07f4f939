"""The node graph (solver/model/graph.py): the pattern of C^T C less its
diagonal is exactly the graph that edge keys a * n + b gave (the previous
implementation, kept here as the reference), on 2D and 3D meshes of every
cell kind, with lattice bonds, carried cells and shells, and on networks."""
import copy

import numpy as np
import pytest

from conftest import raw_scene
from solver.model import arrays as model
from solver.model.binding import from_dict
from solver.model.graph import Graph


def keyed(n_nodes, conns, pairs=None) -> Graph:
    """The previous ContinuumArrays.graph: unique edge keys a * n + b, by chunks."""
    n = np.int64(n_nodes)
    keys = []
    for conn in conns:
        k = conn.shape[1]
        off = ~np.eye(k, dtype=bool)
        for s in range(0, len(conn), 32768):
            c = conn[s:s + 32768].astype(np.int64)
            pair = (c[:, :, None], c[:, None, :])
            key = (pair[0] * n + pair[1])[:, off]
            keys.append(np.unique(key[(pair[0] != pair[1])[:, off]]))
    if pairs is not None:
        bi, bj = (np.asarray(x, np.int64) for x in pairs)
        keep = bi != bj
        keys.append(np.concatenate([bi[keep] * n + bj[keep], bj[keep] * n + bi[keep]]))
    key = np.unique(np.concatenate(keys)) if keys else np.zeros(0, dtype=np.int64)
    a, b = key // n, key % n
    return Graph(np.searchsorted(a, np.arange(n_nodes + 1)).astype(np.int64), b)


def brute(n_nodes, conns) -> Graph:
    """Neighbour sets, one Python set per node."""
    nb = [set() for _ in range(n_nodes)]
    for conn in conns:
        for cell in conn.tolist():
            for a in cell:
                nb[a].update(b for b in cell if b != a)
    rows = [sorted(s) for s in nb]
    indptr = np.concatenate([[0], np.cumsum([len(r) for r in rows])]).astype(np.int64)
    return Graph(indptr, np.array([c for r in rows for c in r], dtype=np.int64))


def same(g: Graph, ref: Graph):
    assert g.indptr.dtype == np.int64
    assert g.indices.dtype == (np.int32 if g.n_nodes < 2 ** 31 else np.int64)
    assert np.array_equal(g.indptr, ref.indptr)
    assert np.array_equal(g.indices, ref.indices)


def model_reference(mdl) -> Graph:
    lat = mdl.lattice
    conns = [c for _, c, _ in list(mdl.cells) + list(lat.carried if lat is not None else ())]
    pairs = lat.bonds[:2] if lat is not None and lat.bonds else None
    return keyed(mdl.n_nodes, conns, pairs)


def tets(h):
    raw = copy.deepcopy(raw_scene("bar3d"))
    mesh = raw["model"]["mesh"].replace("bar3d_coupled.geo", "cube3d.geo")
    raw["model"] = {**{k: v for k, v in raw["model"].items() if k != "lattice"}, "mesh": mesh,
                    "mesh_parameters": {"h": h}, "body": "solid", "fixed": ["bottom"]}
    raw["partitions"] = [{"name": "fem", "method": "fem", "group": "solid",
                          "integrator": "explicit", "ratio": 1}]
    raw["loads"], raw["probes"] = [], []
    return raw


def scene(name, **params):
    raw = copy.deepcopy(raw_scene(name))
    raw["model"]["mesh_parameters"] = {**raw["model"].get("mesh_parameters", {}), **params}
    return raw


# (case, raw scene, what the model must carry, so that the case tests what it says)
CASES = [
    ("2D quads", lambda: raw_scene("wave_bar_fem"), {"quad4"}),
    ("2D triangles", lambda: raw_scene("plate_hole"), {"tri3"}),
    ("3D tetrahedra", lambda: tets(0.15), {"tet4"}),
    ("3D hexahedra + cubic lattice", lambda: scene("bar3d"), {"hex8", "bonds"}),
    ("2D quads + square lattice", lambda: raw_scene("plate_fracture"), {"bonds"}),
    ("2D transition band (carried cells)", lambda: raw_scene("wave_bar_transition"),
     {"carried"}),
    ("shells", lambda: scene("u_tube", nc=24), set()),
]


@pytest.mark.parametrize("case,raw,carries", CASES, ids=[c[0] for c in CASES])
def test_mesh_graph_is_the_edge_key_graph(case, raw, carries):
    mdl = model.build(from_dict(raw()))
    lat = mdl.lattice
    have = {fam.name for fam, _, _ in mdl.cells}
    if lat is not None and lat.bonds:
        have.add("bonds")
    if lat is not None and len(lat.carried):
        have.add("carried")
    assert carries <= have, f"{case}: the model carries {sorted(have)}"
    g = mdl.graph()
    ref = model_reference(mdl)
    assert ref.indices.size > 4 * mdl.n_nodes           # a real mesh, not an empty graph
    same(g, ref)


def test_cells_with_repeated_and_missing_nodes_match_brute_force():
    """Families of different widths, cells that repeat a node (carried bonds do),
    bonds given twice and both ways, and nodes in no cell (empty rows)."""
    rng = np.random.default_rng(7)
    n = 60
    conns = [rng.integers(0, 50, (40, 4)), rng.integers(0, 50, (25, 3)),
             np.array([[51, 51], [52, 53], [53, 52], [52, 53]]), rng.integers(0, 50, (30, 8))]
    conns[0][:5, 1] = conns[0][:5, 0]                 # repeated nodes in a cell
    g = Graph.from_cells(n, conns)
    same(g, brute(n, conns))
    same(g, keyed(n, conns))
    assert g.degree([51, 54, 59]).tolist() == [0, 0, 0]     # a cell of one node is no edge
    assert g.row(52).tolist() == [53] and g.row(53).tolist() == [52]


def test_no_cells_is_an_empty_graph():
    g = Graph.from_cells(5, [np.zeros((0, 4), dtype=np.int64)])
    assert g.indptr.tolist() == [0] * 6 and g.indices.size == 0


def test_network_graph_from_springs():
    """six_dof's springs (ground excluded), and pairs with repeats and self-loops."""
    mdl = model.build(from_dict(raw_scene("six_dof")))
    g = mdl.graph()
    assert g.indptr.tolist() == [0, 1, 3, 5, 7, 9, 10]
    assert g.indices.tolist() == [1, 0, 2, 1, 3, 2, 4, 3, 5, 4]
    a, b = np.array([0, 3, 3, 2, 4, 1]), np.array([1, 3, 0, 1, 0, 0])
    same(Graph.from_pairs(5, a, b), keyed(5, [], (a, b)))


def coo_rcm(nodes, graph):
    """The RCM order as it was computed before: PETSc's rcm of a COO-assembled AIJ
    of the induced subgraph plus its diagonal."""
    from solver.petscutil import init
    P = init()
    n = nodes.size
    local = np.full(graph.n_nodes, -1, dtype=np.int64)
    local[nodes] = np.arange(n)
    r = np.repeat(np.arange(n), graph.degree(nodes))
    c = local[graph.rows(nodes)]
    r = np.concatenate([np.arange(n), r[c >= 0]])
    c = np.concatenate([np.arange(n), c[c >= 0]])
    G = P.Mat().createAIJ((n, n), comm=P.COMM_SELF)
    G.setPreallocationCOO(r.astype(P.IntType), c.astype(P.IntType))
    G.setValuesCOO(np.ones(r.size))
    G.assemble()
    perm, _ = G.getOrdering("rcm")
    out = nodes[perm.getIndices()]
    perm.destroy()
    G.destroy()
    return out


def test_induced_csr_and_rcm_order_match_the_coo_construction():
    """Graph.induced's CSR (sorted rows, empty rows kept) and distribute.rcm made on
    it without copies give the order the COO-assembled matrix gave, on random
    cell graphs, node subsets with isolated nodes, and a structured hex block."""
    from solver.partitions import distribute
    rng = np.random.default_rng(3)
    for trial in range(5):
        n = int(rng.integers(60, 2000))
        g = Graph.from_cells(n, [rng.integers(0, n, (n // 2, 4)), rng.integers(0, n, (n // 4, 2))])
        nodes = np.sort(rng.choice(n, n // 2 + trial, replace=False)) if trial else np.arange(n)
        indptr, indices = g.induced(nodes)
        local = {int(v): i for i, v in enumerate(nodes)}
        for i in rng.choice(nodes.size, 20):
            want = [local[int(v)] for v in g.row(nodes[i]) if int(v) in local]
            assert indices[indptr[i]:indptr[i + 1]].tolist() == want
        assert np.array_equal(distribute.rcm(nodes, g), coo_rcm(nodes, g))
    m = 12
    idx = np.arange((m + 1) ** 3).reshape(m + 1, m + 1, m + 1)
    hexes = np.stack([idx[i:m + i, j:m + j, k:m + k] for i in (0, 1) for j in (0, 1)
                      for k in (0, 1)], -1).reshape(-1, 8)
    g = Graph.from_cells(idx.size, [hexes])
    assert np.array_equal(distribute.rcm(np.arange(idx.size), g), coo_rcm(np.arange(idx.size), g))


def mixed_chain():
    from mixed_dofs import mixed                   # tests/mixed_dofs.py: 1 and 2 DOFs
    return mixed(model.build(from_dict(raw_scene("six_dof"))))


@pytest.mark.parametrize("make,mixed", [(lambda: model.build(from_dict(scene("bar3d"))), False),
                                        (mixed_chain, True)],
                         ids=["uniform 3 DOFs", "mixed 1 and 2 DOFs"])
def test_owned_nonzeros_is_the_brute_force_count(make, mixed, monkeypatch):
    """The cost estimate's nonzeros (dof^2 (nodes + degrees) for one DOF count,
    chunked sums for mixed counts, here in chunks of 2 nodes) against the
    count over every owned node's row, node by node."""
    from solver.partitions import partitioning
    mdl = make()
    g = mdl.graph()
    counts = mdl.dofmap.counts
    owned = np.arange(0, mdl.n_nodes, 3 if mdl.n_nodes > 30 else 1)
    brute = sum(int(counts[i]) * (int(counts[i]) + int(counts[g.row(i)].sum())) for i in owned)
    monkeypatch.setattr(partitioning, "NONZERO_CHUNK", 2)
    assert partitioning.owned_nonzeros(g, owned, mdl.dofmap) == brute > 0
    assert (mdl.dofmap.block is None) == mixed == (len(np.unique(counts)) > 1)


def test_chunked_induced_and_reach_are_the_whole_reads():
    """Graph.induced read a few rows at a time is the one-pass result, and
    Graph.reach is the nodes with their neighbours, each once, sorted."""
    rng = np.random.default_rng(5)
    n = 900
    g = Graph.from_cells(n, [rng.integers(0, n, (400, 4)), rng.integers(0, n, (300, 2))])
    nodes = np.sort(rng.choice(n, 500, replace=False))
    whole = g.induced(nodes, chunk=n)
    for chunk in (1, 7, 64):
        part = g.induced(nodes, chunk=chunk)
        assert all(np.array_equal(a, b) for a, b in zip(part, whole))
    some = rng.choice(n, 40, replace=False)
    want = np.unique(np.concatenate([some, g.rows(some)]))
    assert np.array_equal(g.reach(some, chunk=3), want)


def test_a_ranks_slice_of_the_plan_numbers_what_its_share_reaches():
    """distribute.Distribution.slice_for: a rank keeps its own piece, the
    partition's external nodes and DOF offsets, and the numbering of its held
    nodes and their neighbours (the same numbers as the whole plan's, -1
    beyond them), never an array over every node."""
    from types import SimpleNamespace
    from solver.model import layout as overlap
    from solver.model.dofmap import DofMap
    from solver.partitions import distribute
    m = 10
    idx = np.arange((m + 1) ** 2).reshape(m + 1, m + 1)
    quads = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], -1).reshape(-1, 4)
    g = Graph.from_cells(idx.size, [quads])
    left = idx[:, :6].ravel()
    parts = [SimpleNamespace(name="a", nodes=left),
             SimpleNamespace(name="b", nodes=np.setdiff1d(idx.ravel(), left))]
    lay = overlap.derive(g, parts, [2, 1])
    dofmap = DofMap.uniform(idx.size, 2)
    for p in range(2):
        dist = distribute.split(lay[p], g, 3)
        for k, piece in enumerate(dist.pieces):
            near = g.reach(piece.held)
            part = dist.slice_for(k, near, dofmap)
            assert part.layout is None and isinstance(part.number, distribute.Numbering)
            assert [q is not None for q in part.pieces] == [q == k for q in range(3)]
            assert np.array_equal(part.number[near], dist.number[near])
            far = np.setdiff1d(idx.ravel(), near)
            assert (part.number[far] == -1).all() and far.size
            assert part.dofs(k, dofmap) == dist.dofs(k, dofmap)
            assert np.array_equal(part.held(), np.intersect1d(dist.held(), near))
            assert np.array_equal(part.external, lay[p].external)
            assert part.n_held == dist.n_held and part.n_layers == dist.n_layers
        none = dist.slice_for(None, None, dofmap)
        assert all(q is None for q in none.pieces) and (none.number[idx.ravel()] == -1).all()


def test_incidence_of_columns_is_that_of_the_stacked_cells():
    """A cell family given as a tuple of its columns (a lattice's bond ends,
    never stacked) makes the incidence matrix its [m, k] array makes, with
    missing nodes (-1) left out either way."""
    from solver.model.graph import incidence
    rng = np.random.default_rng(8)
    hexes = rng.integers(0, 50, (30, 8))
    a, b = rng.integers(-1, 50, 40), rng.integers(0, 50, 40)
    for pair in ((a, b), (np.abs(a), b)):
        C1 = incidence([hexes, pair], 50)
        C2 = incidence([hexes, np.stack(pair, axis=1)], 50)
        assert (C1 != C2).nnz == 0 and C1.shape == (70, 50)
        assert np.array_equal(C1.indptr, C2.indptr) and np.array_equal(C1.indices, C2.indices)
    assert incidence([np.zeros((0, 4), int), ()], 5) is None
