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
