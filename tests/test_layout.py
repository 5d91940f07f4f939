"""Boundary, interior and external sets are derived from the connectivity."""
import numpy as np

from solver.model import arrays as model
from solver.model import layout as overlap
from solver.model.binding import load


def layouts(treatment, fem_ratio=5):
    scene = load("configs/six_dof.yaml", [f"partitions.fem.ratio={fem_ratio}"])
    m = model.build(scene)
    return overlap.derive(m.graph(), scene.partitions,
                          overlap.layer_counts(scene.partitions, [treatment] * 2)), m


def test_six_dof_overlap_is_m3_m4_and_k4():
    (fem, dem), m = layouts("taylor")
    assert fem.owned.tolist() == [0, 1, 2] and fem.boundary.tolist() == [2]
    assert fem.interior.tolist() == [0, 1] and fem.external.tolist() == [3]
    assert dem.boundary.tolist() == [3] and dem.interior.tolist() == [4, 5]
    assert dem.external.tolist() == [2] and dem.external_owner.tolist() == [0]
    # the overlap spring k4 (nodes 2-3) is held by both partitions
    for lay in (fem, dem):
        li, lj, k = m.springs_within(lay.held)
        pairs = {tuple(sorted((int(lay.held[i]) if i >= 0 else -1, int(lay.held[j]))))
                 for i, j in zip(li, lj)}
        assert (2, 3) in pairs


def test_layers_treatment_gives_one_layer_per_substep():
    (fem, dem), _ = layouts("layers", fem_ratio=2)
    assert len(fem.layers) == 1                       # the coarse side steps once
    assert [l.tolist() for l in dem.layers] == [[2], [1]]
    (fem, dem), _ = layouts("layers", fem_ratio=20)   # runs out of nodes after three layers
    assert [l.tolist() for l in dem.layers] == [[2], [1], [0]]
    assert dem.local(np.array([3, 0, 2])).tolist() == [0, 5, 3]


def brute_layouts(graph, partitions, n_layers):
    """Layouts node by node, with Python sets: boundary = owned nodes with a
    neighbour owned elsewhere (or by nobody); layer l + 1 = the neighbours of
    layer l not seen yet."""
    n = graph.n_nodes
    owner = overlap.owner_map(n, partitions)
    out = []
    for p, part in enumerate(partitions):
        owned = sorted(set(int(i) for i in part.nodes))
        boundary = [i for i in owned if any(owner[j] != p for j in graph.row(i))]
        seen, front, layers = set(owned), owned, []
        for _ in range(n_layers[p]):
            layer = sorted({int(j) for i in front for j in graph.row(i)} - seen)
            if not layer:
                break
            layers.append(layer)
            seen |= set(layer)
            front = layer
        out.append((owned, boundary, layers))
    return out


def test_derive_in_chunks_is_the_brute_force_layout(monkeypatch):
    """derive reads the neighbour lists in chunks (here of 5 nodes, so every
    set spans many): the same owned, boundary, interior and layered external
    nodes as the node-by-node construction, on a 2D lattice coupling and a
    transition band, with 1 and 3 layers."""
    from conftest import raw_scene
    from solver.model.binding import from_dict
    monkeypatch.setattr(overlap, "CHUNK", 5)
    for name in ("wave_bar", "wave_bar_transition"):
        scene = from_dict(raw_scene(name))
        graph = model.build(scene).graph()
        for layers in (1, 3):
            got = overlap.derive(graph, scene.partitions, [layers] * len(scene.partitions))
            want = brute_layouts(graph, scene.partitions, [layers] * len(scene.partitions))
            for lay, (owned, boundary, ext) in zip(got, want):
                assert lay.owned.tolist() == owned and lay.boundary.tolist() == boundary
                assert lay.interior.tolist() == sorted(set(owned) - set(boundary))
                assert [x.tolist() for x in lay.layers] == ext and len(ext) == layers
                assert lay.boundary.size > 5
