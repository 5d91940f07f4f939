"""model.integration: selective (the lambda term at the cell centre): no
volumetric locking in a near-incompressible plane-strain cantilever, exact
for uniform strain in hex8, and the guard's stable step follows it."""
import numpy as np
import pytest

from conftest import ROOT, raw_scene, run_cli, run_scene, write_scene

E, L, H, Q = 1e9, 0.1, 0.01, 1e3          # meshes/cantilever.geo's strip, tip traction Q [N/m]


def cantilever(nu, integration, ny, **over):
    raw = {"name": "cantilever", "analysis": "static", "time": {"end": 1.0},
           "model": {"kind": "continuum", "mesh": str(ROOT / "meshes" / "cantilever.geo"),
                     "mesh_parameters": {"nx": 10 * ny, "ny": ny},
                     "material": {"E": E, "nu": nu, "rho": 1000.0, "kind": "plane_strain"},
                     "body": "solid", "fixed": ["left"], "integration": integration},
           "loads": [{"group": "right", "kind": "rectangular", "amplitude": Q, "duration": 2.0,
                      "direction": [0, 1]}],
           "probes": [{"name": "tip", "at": [L, H / 2], "component": 1}]}
    raw.update(over)
    return raw


def dynamic_cantilever(nu, integration, ny, dt):
    """The cantilever as one explicit partition, 10 steps of ``dt``."""
    raw = cantilever(nu, integration, ny)
    del raw["analysis"]
    raw.update(time={"end": 10 * dt, "dt": dt},
               partitions=[{"name": "fem", "method": "fem", "group": "solid",
                            "integrator": "explicit", "ratio": 1}])
    return raw


def timoshenko(nu):
    """Tip deflection of the plane-strain cantilever: bending with E / (1 - nu^2)
    plus shear with kappa = 5/6."""
    P, I, G = Q * H, H ** 3 / 12, E / (2 * (1 + nu))
    return P * L ** 3 / (3 * E / (1 - nu ** 2) * I) + P * L / (5 / 6 * G * H)


@pytest.mark.parametrize("nu, ny, full_below, selective_within", [
    (0.4999, 4, 0.05, 0.015),        # full integration locks: 2 % of the deflection
    (0.4999, 8, 0.1, 0.02),
    (0.3, 4, 0.97, 0.01),            # compressible: selective no worse, also within 1 %
])
def test_a_near_incompressible_cantilever_does_not_lock(nu, ny, full_below, selective_within,
                                                        tmp_path):
    ref = timoshenko(nu)
    full = run_scene(cantilever(nu, "full", ny), tmp_path).probes["tip"]["displacement"][0]
    sel = run_scene(cantilever(nu, "selective", ny), tmp_path).probes["tip"]["displacement"][0]
    assert full / ref < full_below, full / ref
    assert abs(sel / ref - 1) < selective_within, sel / ref


def test_selective_hex8_is_exact_for_uniform_strain(tmp_path):
    """configs/bar3d.yaml's hexahedra (no lattice) prestrained u = eps x: the
    strain energy is (lambda + 2 mu) eps^2 / 2 per volume with either
    integration (the centre term is exact for a linear field)."""
    eps, nu = 1e-4, 0.25
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    for integration in ("full", "selective"):
        raw = raw_scene("bar3d")
        del raw["model"]["lattice"], raw["model"]["fixed"]
        raw["model"].update(material={"E": E, "nu": nu, "rho": 1000.0, "kind": "solid"},
                            integration=integration)
        raw.update(loads=[], time={"end": 2e-7, "dt": 2e-8},
                   partitions=[{"name": "fem", "method": "fem", "group": "solid",
                                "integrator": "explicit", "ratio": 1}],
                   initial={"motion": [{"displacement": [f"{eps} * x", 0, 0]}]})
        strain = run_scene(raw, tmp_path).energy["strain"][0]
        volume = 0.02 * 0.0024 * 0.0008
        assert abs(strain / ((lam + 2 * mu) * eps ** 2 / 2 * volume) - 1) < 1e-12, integration


def test_the_stable_step_follows_the_integration(tmp_path):
    """nu = 0.4999: the dilatational wave (c_p of lambda + 2 mu) bounds the step
    either way; selective's highest mode is a little slower (its critical
    step 2.5 % longer here), and the guard refuses just above it and runs
    just below it."""
    def dynamic(integration, dt):
        return dynamic_cantilever(0.4999, integration, 2, dt)
    crit = {}
    for integration in ("full", "selective"):
        res = run_scene(dynamic(integration, 1e-9), tmp_path)
        crit[integration] = res.partitions["fem"]["critical_step"]
    assert crit["full"] < crit["selective"] < 1.1 * crit["full"], crit
    c = crit["selective"]
    for factor, code in ((1.01, 2), (0.99, 0)):
        raw = dynamic("selective", factor * c)
        raw["output"] = {"file": str(tmp_path / f"s{factor}.h5")}
        proc = run_cli([write_scene(tmp_path / f"s{factor}.yaml", raw)])
        assert proc.returncode == code, (factor, proc.stderr)
        if code:
            assert "critical step" in proc.stderr, proc.stderr
