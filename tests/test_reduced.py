"""model.integration: reduced (one point, Flanagan-Belytschko hourglass
stiffness, model.hourglass): exact for linear fields on distorted quad4 and
hex8 cells with only the rigid modes free, hourglass modes held in
proportion to the coefficient, no volumetric locking, the guard's step, and
the refusals."""
import numpy as np
import pytest

from conftest import raw_scene, refused, run_cli, run_scene, write_scene
from solver.model import elements as el
from test_selective import cantilever, dynamic_cantilever, timoshenko


@pytest.mark.parametrize("family, nodes", [(el.QUAD4, el.QUAD_NODES), (el.HEX8, el.HEX_NODES)])
def test_linear_fields_exact_and_hourglass_modes_held(family, nodes):
    """20 distorted cells: K u for a linear field u is full integration's
    (1e-13: the mean gradients make the patch test exact), exactly the rigid
    modes are free (3 in 2D, 6 in 3D), and an hourglass mode's energy grows
    linearly with model.hourglass."""
    rng = np.random.default_rng(0)
    X = (nodes * 0.5 + 0.5)[None] + 0.1 * rng.standard_normal((20,) + nodes.shape)
    kind = "plane_strain" if family.dim == 2 else "solid"

    def K(integration, c=0.1):
        return el.stiffness(family, X, el.Elastic(2e11, 0.3, 7800.0, kind, 1.0, integration, c))
    d = family.dim
    u = (X @ rng.standard_normal((d, d)).T + rng.standard_normal(d)).reshape(20, -1)
    full = np.einsum("eij,ej->ei", K("full"), u)
    assert np.abs(np.einsum("eij,ej->ei", K("reduced"), u) - full).max() < 1e-13 * np.abs(full).max()
    ev = np.linalg.eigvalsh(K("reduced"))
    assert ((np.abs(ev) < 1e-10 * ev.max(axis=1, keepdims=True)).sum(axis=1) == 3 * (d - 1)).all()
    h = np.prod(nodes[:, :2], axis=1)                               # the xi eta mode in x
    mode = np.zeros((20, family.n_nodes, d))
    mode[:, :, 0] = h
    mode = mode.reshape(20, -1)
    energy = [np.einsum("ei,eij,ej->e", mode, K("reduced", c), mode) for c in (0.1, 0.2)]
    assert np.allclose(energy[1] / energy[0], 2.0, rtol=0.2) and (energy[0] > 0).all()


@pytest.mark.parametrize("nu, ny, within", [(0.4999, 4, 0.01), (0.3, 8, 0.01), (0.4999, 8, 0.02)])
def test_the_cantilever_does_not_lock(tmp_path, nu, ny, within):
    """meshes/cantilever.geo, plane strain, against Timoshenko: reduced with
    the default hourglass 0.1 gives 1.002 (nu 0.4999, 4 cells deep; full
    integration 0.021), 0.998 (nu 0.3, 8 deep) and 0.987 (nu 0.4999, 8 deep)."""
    got = run_scene(cantilever(nu, "reduced", ny), tmp_path).probes["tip"]["displacement"][0]
    assert abs(got / timoshenko(nu) - 1) < within, got / timoshenko(nu)


def test_cook_membrane_reduced(tmp_path):
    """Cook's membrane at nu = 0.4999, 16 x 16: 0.978 of the extrapolated
    27.73 (selective 0.972, full 0.30)."""
    raw = raw_scene("cook_membrane")
    raw["model"].update(mesh_parameters={"n": 16, "quads": 1}, integration="reduced")
    raw["model"]["material"]["nu"] = 0.4999
    got = run_scene(raw, tmp_path).probes["C"]["displacement"][0]
    assert got / 27.73 == pytest.approx(0.978, abs=0.006)


def test_the_guard_knows_the_reduced_step(tmp_path):
    """The 4-deep cantilever at nu = 0.3, dynamic: the highest mode is still
    the cells' dilatation, so the one-point cells' critical step is full
    integration's within 1 % (0.5 % longer); refused at 1.01 x it, runs at
    0.99 x."""
    def dynamic(integration, dt):
        return dynamic_cantilever(0.3, integration, 4, dt)
    crit = {i: run_scene(dynamic(i, 1e-9), tmp_path).partitions["fem"]["critical_step"]
            for i in ("full", "reduced")}
    assert crit["full"] <= crit["reduced"] < 1.01 * crit["full"], crit
    for factor, code in ((1.01, 2), (0.99, 0)):
        raw = dynamic("reduced", factor * crit["reduced"])
        raw["output"] = {"file": str(tmp_path / f"r{factor}.h5")}
        proc = run_cli([write_scene(tmp_path / f"r{factor}.yaml", raw)])
        assert proc.returncode == code, (factor, proc.stderr)


@pytest.mark.parametrize("sets, message", [
    (["model.integration=reduced", "model.hourglass=0"], "model.hourglass: "),
    (["model.integration=reduced", "model.hourglass=1.5"],
     "model.hourglass: 1.5 is out of range: 0 < hourglass <= 1"),
    (["model.hourglass=0.2"], "model.hourglass: is for integration: reduced"),
])
def test_bad_hourglass_is_refused(tmp_path, sets, message):
    line = refused("configs/cook_membrane.yaml", sets, tmp_path)
    assert message in line, line
