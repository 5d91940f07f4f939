"""Heat: conduction with a laser spot, thermal expansion, temperature-weakened
bonds (solver/model/heat.py, solver/partitions/thermal.py, issue 10)."""
from __future__ import annotations

import types

import h5py
import numpy as np
import pytest

from conftest import raw_scene, refused, run_cli, run_scene, write_scene

ALPHA, DT = 2.3e-5, 50.0


def centre_rise(t, rho=2700.0, c=900.0, h=6.5e-4, k=233.0, A=0.15, I=2.5e6, R=0.01):
    """T - T0 at the centre of a Gaussian spot on an infinite insulated plate."""
    kappa = k / (rho * c)
    return A * 2 * I / (rho * c * h) * R ** 2 / (8 * kappa) * np.log(1 + 8 * kappa * t / R ** 2)


def test_laser_heating_matches_the_gaussian_solution_at_second_order(tmp_path):
    """Centre temperature after 0.1 s of heating on meshes of 4, 2, 1 mm (thermal
    step ~ h^2): relative errors 1.4e-2, 2.9e-3, 6.8e-4, order > 1.9."""
    errors = []
    for h in (0.004, 0.002, 0.001):
        raw = raw_scene("laser_disc")
        raw["model"]["mesh_parameters"]["h"] = h
        step = 1.6e-2 * (h / 0.004) ** 2
        raw["heat"]["step"] = step
        raw["time"]["end"] = (round(0.1 / step) + 1) * 1e-7
        raw["output"].pop("fields")
        res = run_scene(raw, tmp_path)
        th, T = res.heat["heating_time"][-1], res.heat["max_temperature"][-1]
        errors.append(abs((T - 293.0) / centre_rise(th) - 1))
    order = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] < 1e-3 and np.all(order > 1.9), (errors, order)


def built(raw, tmp_path):
    from mpi4py import MPI

    from solver import scene as scene_mod
    from solver.driver.build import build
    from solver.model import binding
    from solver.petscutil import init
    init([])
    raw = dict(raw, output={"file": str(tmp_path / "h.h5")})
    return build(binding.bind(scene_mod.from_dict(raw)), MPI.COMM_SELF)


def heated(raw):
    raw["loads"] = []
    raw.pop("reference", None)
    raw["heat"] = {"conductivity": 233.0, "specific_heat": 900.0, "expansion": ALPHA,
                   "step": 1e-6, "every": 1}
    return raw


def beams(raw):
    """``raw`` with a random packing of rotating particles joined by beams."""
    raw["model"]["material"]["nu"] = 0.25
    raw["model"]["lattice"].update(kind="random", geometry="nonlinear", bond="beam")
    return raw


@pytest.mark.parametrize("scene, geometry", [("wave_bar_transition", "linear"),
                                             ("wave_bar_transition", "nonlinear"),
                                             ("wave_bar_transition", "beam"),
                                             ("wave_bar_transition", "volumetric"),
                                             ("wave_bar_transition", "volumetric linear"),
                                             ("wave_bar", "linear"), ("wave_bar", "nonlinear")])
def test_free_thermal_expansion_is_stress_free(scene, geometry, tmp_path):
    """u = alpha dT (X - X_c) at a uniform dT: FE cells, bonds carried to the
    transition band, overlap cells and lattice bonds (small-strain or
    current-configuration; beams between rotating particles, which do not
    turn, and the beams carried to the band, whose FE cells carry three DOFs
    per node; central bonds with the volumetric term of nu 0.4) all balance
    to round-off (1e-9 of the thermal forces)."""
    raw = heated(raw_scene(scene))
    if geometry == "beam":
        raw = beams(raw)
    elif geometry.startswith("volumetric"):      # nu 0.4: central bonds + the volumetric term
        raw["model"]["material"]["nu"] = 0.4
        raw["model"]["lattice"].update(kind="random", geometry=geometry.split()[-1]
                                       .replace("volumetric", "nonlinear"))
    else:
        raw["model"]["lattice"]["geometry"] = geometry
    asm = built(raw, tmp_path)
    T = np.full(asm.model.n_nodes, 293.0 + DT)
    for p in asm.parts:
        p.set_temperature(T, count=False)
        X = asm.model.points[p.layout.held]
        free = np.zeros((len(X), p.U.size // len(X)))         # rotations: none
        free[:, :X.shape[1]] = ALPHA * DT * (X - X.mean(axis=0))
        p.U[:] = free.ravel()
        p.residual(0.0, p.u, None)
        n = p.n_own
        forces = np.abs(p.thermal.force[:n]).max() if p.thermal is not None else 0.0
        if p.method == "dem" and p.force.bonded:                # the bonds' own expansion
            f = p.force
            forces = max(forces, (f.k * f.L_cold).max() * ALPHA * DT)
        assert forces > 1.0 and np.abs(p.R[:n]).max() < 1e-9 * forces
    asm.destroy()


def test_a_bar_held_between_walls_carries_the_exact_thermal_stress(tmp_path):
    """A strip 40 x 8 mm between walls (u_x = 0) at dT = 50 K: the uniaxial field
    u_y = (1 + nu) alpha dT (y - y_c) balances every free node to round-off, the
    stress at a probe is -E alpha dT exactly and the walls push with E alpha dT W t."""
    from solver.driver.stress import build as stress_probes
    raw = heated(raw_scene("laser_disc"))
    raw["model"]["mesh_parameters"] = {"L": 0.04, "W": 0.008, "h": 0.002}
    raw["probes"] = [{"name": "P", "at": [0.02, 0.004], "component": 0}]
    asm = built(raw, tmp_path)
    mdl, (p,) = asm.model, asm.parts
    T = np.full(mdl.n_nodes, 293.0 + DT)
    p.set_temperature(T, count=False)
    X = mdl.points[p.layout.held]
    nu, E, t = 0.33, 70e9, 6.5e-4
    U = np.zeros_like(X)
    U[:, 1] = (1 + nu) * ALPHA * DT * (X[:, 1] - 0.004)
    p.U[:] = U.ravel()
    p.residual(0.0, p.u, None)
    R = p.R.reshape(-1, 2)
    wall = np.isclose(X[:, 0], 0.0) | np.isclose(X[:, 0], 0.04)
    sigma = E * ALPHA * DT
    assert np.abs(R[~wall]).max() < 1e-9 * sigma * t * 0.002
    assert np.abs(R[wall, 1]).max() < 1e-9 * sigma * t * 0.002
    push = R[np.isclose(X[:, 0], 0.04), 0].sum()              # what the right wall must hold
    assert abs(push / (sigma * 0.008 * t) - 1) < 1e-12
    probes = stress_probes(_scene(raw, tmp_path), mdl, asm.parts)
    probes.heating = types.SimpleNamespace(T_node=T, spec=mdl.heat.spec)
    assert abs(probes.values()["P"] / -sigma - 1) < 1e-12
    asm.destroy()


def test_a_heated_plate_split_over_ranks_matches_one_rank(tmp_path):
    """laser_disc with expansion (a thermal shock: heating 4000 x faster than
    real) on 1, 2 and 4 ranks, the fem partition split (the temperature field
    and its thermal forces distributed with it): displacement and stress at a
    probe agree to 1e-12 of their peaks, the thermal work to 1e-12."""
    out = {}
    for n in (1, 2, 4):
        raw = raw_scene("laser_disc")
        raw["heat"].update(expansion=2.3e-5, every=10)
        raw["time"]["end"] = 2.6e-5
        raw["probes"] = [{"name": "P", "at": [0.05, 0.04], "component": 0}]
        raw["output"] = {"file": str(tmp_path / f"d{n}.h5"), "progress": 0}
        proc = run_cli([write_scene(tmp_path / f"d{n}.yaml", raw)], n=n, timeout=120)
        assert proc.returncode == 0, proc.stderr
        with h5py.File(tmp_path / f"d{n}.h5") as f:
            out[n] = (f["probes/P/displacement"][()], f["probes/P/stress"][()],
                      f["energy/external_work"][-1])
    for n in (2, 4):
        for a, b in zip(out[1][:2], out[n][:2]):
            assert np.abs(a).max() > 0 and np.abs(a - b).max() <= 1e-12 * np.abs(a).max(), n
        assert out[1][2] > 0 and abs(out[n][2] / out[1][2] - 1) < 1e-12, n


def _scene(raw, tmp_path):
    from solver import scene as scene_mod
    from solver.model import binding
    return binding.bind(scene_mod.from_dict(dict(raw, output={"file": str(tmp_path / "h.h5")})))


def test_heated_bonds_weaken_and_break_with_their_temperature(tmp_path):
    """A lattice stretched by 1e-4 along x: x bonds strain 1e-4, diagonals 5e-5.
    At T with a critical strain of 7.5e-5 (break_strain 1e-4, melting 993 K:
    T = 293 + 0.25 x 700 K) the x bonds break, the diagonals hold; the record
    gives strain, critical strain and temperature."""
    raw = heated(raw_scene("wave_bar_transition"))
    raw["model"]["lattice"].update(geometry="nonlinear", break_strain=1e-4)
    raw["heat"]["melting"] = 993.0
    raw["heat"]["expansion"] = 0.0
    asm = built(raw, tmp_path)
    dem = next(p for p in asm.parts if p.method == "dem")
    f = dem.force
    T = np.full(asm.model.n_nodes, 293.0 + 0.25 * 700.0)
    dem.set_temperature(T, count=False)
    assert np.allclose(f.limit, 7.5e-5)
    X = f.X[:f.n_held]
    dem.U[:] = np.stack([1e-4 * X[:, 0], 0 * X[:, 1]], 1).ravel()
    dem.residual(0.0, dem.u, None)
    d = f.X[f.j] - f.X[f.i]
    along_x = np.abs(d[:, 1]) < 1e-12
    assert not f.alive[along_x].any() and f.alive[~along_x].all()
    rows = np.array(f.broken)
    assert rows.shape[1] == 8 and np.allclose(rows[:, 3], 1e-4, rtol=1e-6)
    assert np.allclose(rows[:, 4], 7.5e-5) and np.allclose(rows[:, 5], 468.0)
    asm.destroy()


def test_heated_beams_rest_longer_weaken_and_break_with_their_temperature(tmp_path):
    """Beams between rotating particles at T = 293 + 0.25 x 700 K (melting
    993 K, break_strain 1e-4, shear_ratio 0.5): their rest lengths grow by
    alpha dT, their tensile and shear strengths fall to 7.5e-5 and 3.75e-5;
    expanded freely and stretched by 1e-4 along x, exactly the beams whose outer fibre or shear
    strain exceeds the weakened strength break, some of them below the cold
    strength, each recorded with its temperature."""
    raw = beams(heated(raw_scene("wave_bar_transition")))
    raw["model"]["lattice"].update(break_strain=1e-4, shear_ratio=0.5)
    raw["heat"]["melting"] = 993.0
    asm = built(raw, tmp_path)
    dem = next(p for p in asm.parts if p.method == "dem")
    f = dem.force
    cold = f.beams.L0.copy()
    T = np.full(asm.model.n_nodes, 293.0 + 0.25 * 700.0)
    dem.set_temperature(T, count=False)
    assert np.allclose(f.beams.L0, cold * (1 + ALPHA * 175.0), rtol=1e-14)
    assert np.allclose(f.beams.tension, 7.5e-5) and np.allclose(f.beams.shear, 3.75e-5)
    X = f.X[:f.n_held]
    q = np.zeros((f.n_held, 3))
    q[:, :2] = ALPHA * 175.0 * (X - X.mean(axis=0))              # the free expansion, then
    q[:, 0] += 1e-4 * X[:, 0]                                    # the stretch
    dem.U[:] = q.ravel()
    dem.residual(0.0, dem.u, None)
    fibre, slip, tension, shear = f.beams.failure(q[:, :2], q[:, 2])
    beyond = (fibre > tension) | (slip > shear)
    assert beyond.any() and np.array_equal(~f.alive, beyond)
    assert (fibre[beyond] < 1e-4).any()                         # weakened by the heat
    rows = np.array(f.broken)
    assert len(rows) == beyond.sum() and np.allclose(rows[:, 5], 468.0)
    asm.destroy()


@pytest.mark.parametrize("sets, message", [
    (["heat.laser.centre=[0.1, 0.04]"], "heat.laser.centre: [0.1, 0.04] lies off the plate"),
    (["heat.step=0.05"], "heat.step: 0.05 s is beyond the explicit conduction limit 0.02"),
    (["heat.melting=250"], "heat.melting: 250 K is not above heat.initial 293 K"),
    (["heat.melting=900"], "heat.melting: weakens breakable bonds: needs model.lattice.break_strain"),
    (["model.material.kind=plane_strain"], "heat.laser: needs model.material.kind plane_stress"),
    (["heat.laser.absorptivity=1.5"], "heat.laser.absorptivity: 1.5: a fraction of the light"),
    (["heat.conductivity=-3"], "heat.conductivity"),
])
def test_bad_heat_input_is_refused_in_one_line(sets, message, tmp_path):
    line = refused("configs/laser_disc.yaml", sets, tmp_path)
    assert message in line, line
