"""External-data treatments, checked on the external nodes themselves.

six_dof cannot tell the treatments apart (all stay below 1e-5), so these
tests look at what each treatment does to the DEM partition's external copy of
m3 during one system step of eta sub-steps.
"""
import numpy as np
import pytest
from mpi4py import MPI

from solver import scene as scene_mod

from solver.model import binding
from solver.driver.build import build

ETA = 10


def dem_after_warmup(treatment):
    scene = binding.load("configs/six_dof.yaml", [f"partitions.fem.ratio={ETA}",
                                                    f"coupling.external={treatment}"])
    asm = build(scene, MPI.COMM_SELF)
    for s in range(300):                       # a non-trivial state: t = 0.3 s
        asm.scheme.step(s * scene.system_dt)
    fem, dem = asm.parts
    return scene, asm, fem, dem


def test_taylor_external_data_follow_the_predictor():
    scene, asm, fem, dem = dem_after_warmup("taylor")
    n = dem.n_own
    x0, v0, a0 = dem.state[:, n:].copy()
    assert np.abs(a0).max() > 1e-3                        # something to predict
    dem.advance(300 * scene.system_dt)
    s = ETA * dem.dt
    x_pred = x0 + s * v0 + 0.5 * s * s * a0
    assert np.allclose(dem.U[n:], x_pred, rtol=1e-13, atol=0)
    assert np.allclose(dem.V[n:], v0 + s * a0, rtol=1e-13, atol=0)
    assert np.array_equal(dem.A[n:], a0)
    asm.destroy()


@pytest.mark.parametrize("treatment,layers", [("literal", 1), ("layers", ETA)])
def test_integrated_external_data_use_partial_forces(treatment, layers):
    scene, asm, fem, dem = dem_after_warmup(treatment)
    assert len(dem.layout.layers) == min(layers, 3)        # the chain has three FEM nodes
    n = dem.n_own
    a_before = dem.A[n:].copy()
    dem.advance(300 * scene.system_dt)
    # integrated externals: their accelerations were recomputed from the
    # partition's own springs, so they moved away from the exchanged values
    assert not np.array_equal(dem.A[n:], a_before)
    # after the exchange every external copy equals its owner's value again
    asm.scheme.exchange()
    position = {node: i for i, node in enumerate(fem.layout.owned.tolist())}
    rows = [position[node] for node in dem.layout.external.tolist()]
    assert np.array_equal(dem.state[:, n:], fem.state[:, rows])       # u, v and a
    asm.destroy()
