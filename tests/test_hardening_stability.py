"""The critical-step estimate (stability.py, lanczos.py) and the guard's messages."""
import re
import sys
import warnings

import h5py
import numpy as np
import pytest

from conftest import ROOT, mpiexec, raw_scene, refused, run_cli, run_scene, write_scene
from solver.errors import SceneError


def laplacian(n):
    """3D 7-point Laplacian on n^3 interior points (fixed walls): its largest
    eigenvalue is 12 sin^2(n pi / (2 (n + 1)))."""
    from scipy.sparse import diags, identity, kron
    T = diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    eye = identity(n)
    return (kron(kron(T, eye), eye) + kron(kron(eye, T), eye) + kron(kron(eye, eye), T)).tocsr()


def test_lanczos_estimate_brackets_the_exact_eigenvalue():
    """theta <= lambda_max <= theta / (1 - eps) on a 20^3 Laplacian (8000 DOF, a
    dense top of the spectrum), with theta exact to 1e-10 after the bound's steps."""
    from solver.model import lanczos
    from solver.partitions import stability
    n = 20
    A = laplacian(n)
    exact = 12 * np.sin(n * np.pi / (2 * (n + 1))) ** 2
    k = lanczos.steps(A.shape[0], stability.LANCZOS_EPS, stability.LANCZOS_FAILURE)
    assert 200 <= k <= 240          # 1.648 sqrt(8000) exp(-sqrt(2e-3) (2k - 1)) <= 1e-6
    assert 1.648 * np.sqrt(8000) * np.exp(-np.sqrt(2e-3) * (2 * k - 1)) <= 1e-6
    theta, done = lanczos.largest(A.dot, lanczos.start(np.arange(A.shape[0])), k)
    assert done == k
    assert exact * (1 - 1e-10) <= theta <= exact * (1 + 1e-12)
    assert theta / (1 - stability.LANCZOS_EPS) >= exact


def test_start_vector_is_a_function_of_the_dof_ids():
    from solver.model import lanczos
    ids = np.arange(1000)
    v = lanczos.start(ids)
    assert np.array_equal(lanczos.start(ids[::-1]), v[::-1])
    assert -1 <= v.min() < -0.99 and 0.99 < v.max() < 1 and abs(v.mean()) < 0.05


def partition_operator(name, p=0):
    from solver.model import layout as overlap
    from solver.model import arrays
    from solver.model.arrays import dof_masses
    from solver.model.binding import from_dict
    scene = from_dict(raw_scene(name))
    mdl = arrays.build(scene, [1] * len(scene.partitions))
    lay = overlap.derive(mdl.graph(), scene.partitions, [1] * len(scene.partitions))[p]
    dm = mdl.dofmap
    spec = scene.partitions[p]
    blocks = mdl.bond_blocks(lay.held) if spec.method == "dem" else mdl.stiffness_blocks(lay.held)
    mass = np.where(mdl.fixed[dm.dofs(lay.held)], np.inf, dof_masses(mdl, lay.held))
    return blocks, lay.held, mass, dm, mdl


@pytest.mark.parametrize("name,p,method", [("bar3d", 0, "Lanczos"), ("plate_shell", 0, "Lanczos"),
                                           ("metamaterial", 1, "Gershgorin bound")])
def test_estimate_is_within_its_margin_above_the_exact_omega(name, p, method, monkeypatch):
    """Lanczos before PETSc, on the PETSc operator, and the dense eigenvalue:
    both estimates lie in [1, (1 - eps)^-1/2] x the exact omega_max and agree
    to 1e-10 (tets and hexes; shells with rotary inertia; a lattice's bonds,
    whose Gershgorin bound is within 0.2 % of the truth and caps the estimate)."""
    from solver.partitions import stability
    from solver.partitions.assembly import default_type, matrix
    from solver.petscutil import init
    P = init([])
    blocks, held, mass, dm, mdl = partition_operator(name, p)
    assert stability.EXACT_LIMIT < mass.size <= stability.PREBUILD_LIMIT
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fast = stability.omega_max(blocks, held, mass, dm, "x")
        monkeypatch.setattr(stability, "EXACT_LIMIT", 10 ** 9)
        exact = stability.omega_max(blocks, held, mass, dm, "x")
        monkeypatch.undo()
        number = np.full(mdl.n_nodes, -1, dtype=np.int64)
        number[held] = np.arange(held.size)[::-1]             # another row order
        K = matrix(lambda: blocks, number, held.size, held.size, 0, dm, P.COMM_SELF, "t_",
                   scale=-1.0, mat_type=default_type(dm.block))
        still = ~np.isfinite(mass)
        ids = dm.dofs(held)
        rows = (number[held][:, None] * dm.block + np.arange(dm.block)).ravel()
        perm = np.empty_like(rows)                              # row -> model order
        perm[rows] = np.arange(rows.size)
        assembled = stability.from_operator(K, np.where(still, 1.0, mass)[perm], still[perm],
                                            ids[perm], "x")
        K.destroy()
    assert fast.method == assembled.method == method and exact.method == "exact"
    ratio = fast.omega_max / exact.omega_max
    assert 1.0 <= ratio <= 1 / np.sqrt(1 - stability.LANCZOS_EPS) + 1e-9, ratio
    if method == "Lanczos":                  # theta is exact by then
        assert ratio == pytest.approx(1 / np.sqrt(1 - stability.LANCZOS_EPS), rel=1e-9)
    assert assembled.omega_max == pytest.approx(fast.omega_max, rel=1e-10)


def test_nothing_to_step_and_non_finite_operators():
    """Every DOF held: omega_max 0, no critical step, no warning; a NaN or an
    overflowing entry: one SceneError line naming the partition."""
    from solver.errors import SceneError
    from solver.partitions import stability
    from solver.petscutil import aij, init
    P = init([])
    blocks, held, mass, dm, _ = partition_operator("bar3d")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fr = stability.omega_max(blocks, held, np.full(mass.size, np.inf), dm, "fem")
        assert fr.omega_max == 0.0 and fr.method == stability.NOTHING
        assert fr.critical_step() == np.inf
        for bad in (np.nan, 1e-320):               # a NaN mass; a mass whose 1/m overflows
            m = mass.copy()
            m[np.flatnonzero(np.isfinite(m))[5]] = bad
            with pytest.raises(SceneError) as e:
                stability.omega_max(blocks, held, m, dm, "fem")
            assert str(e.value).startswith("partition 'fem': M^-1 K has a NaN or infinite entry")
            assert "\n" not in str(e.value)
        # the assembled path: nothing to step, then a NaN entry
        n = 4
        rows, cols = np.repeat(np.arange(n), n), np.tile(np.arange(n), n)
        vals = -np.eye(n).ravel() * 2.0
        K = aij(rows, cols, vals, n, P.COMM_SELF, "t_")
        ids = np.arange(n)
        fr = stability.from_operator(K, np.ones(n), np.ones(n, bool), ids, "dem")
        assert fr.omega_max == 0.0 and fr.method == stability.NOTHING
        fr = stability.from_operator(K, np.full(n, 0.5), np.zeros(n, bool), ids, "dem")
        assert fr.omega_max == pytest.approx(2.0, rel=1e-12)      # 2 / 0.5 = 4 = omega^2
        # omega^2 = 2e300: the Lanczos vectors' norms would overflow unscaled
        fr = stability.from_operator(K, np.full(n, 1e-300), np.zeros(n, bool), ids, "dem")
        assert fr.omega_max == pytest.approx(np.sqrt(2e300), rel=1e-12)
        K.destroy()
        vals[5] = np.nan
        K = aij(rows, cols, vals, n, P.COMM_SELF, "t_")
        with pytest.raises(SceneError, match=r"^partition 'dem': M\^-1 K has a NaN"):
            stability.from_operator(K, np.ones(n), np.zeros(n, bool), ids, "dem")
        K.destroy()


@pytest.mark.parametrize("thickness,message", [
    ("1e-200", "error: partition 'plate': M^-1 K has a NaN or infinite entry"),   # masses underflow
    ("1e-100", "error: partition 'plate': step 1.5e-06 s (ratio 1 x time.dt 1.5e-06 s) is "
               "unstable, critical step 1.71e-104 s (omega_max 1.169e+104 rad/s, Lanczos)")])
def test_absurdly_thin_shells_are_refused_in_one_line(thickness, message, tmp_path, monkeypatch):
    """Rotary inertia ~ t^3: at t = 1e-100 m omega_max is 1e104 rad/s (estimated
    without overflow), at 1e-200 m the masses underflow to 0.  The scene's own
    rule (a wall thicker than 1e-6 x its smallest edge) refuses both first; with
    that rule off, the estimator still answers in one line."""
    line = refused(ROOT / "configs" / "plate_shell.yaml",
                   [f"model.material.thickness={thickness}", "time.end=3e-6"], tmp_path)
    assert "thicker than 1e-06 x its smallest element edge" in line, line
    from solver.model import binding
    monkeypatch.setattr(binding, "THINNEST_WALL", 0.0)
    raw = raw_scene("plate_shell")
    raw["model"]["material"]["thickness"] = float(thickness)
    raw["time"]["end"] = 3e-6
    with pytest.raises(SceneError) as err:
        run_scene(raw, tmp_path)
    assert f"error: {err.value}".startswith(message), str(err.value)


def test_seconds_print_enough_digits_to_differ():
    from solver.partitions.stability import seconds
    assert seconds(1.0400001, 1.04) == ["1.0400001", "1.04"]
    assert seconds(2.0e-8, 2.0e-8) == ["2e-08", "2e-08"]
    assert seconds(8e-20) == ["8e-20"]
    assert seconds(1 + 1e-12, 1.0) == ["1", "1"]           # at most 10 digits


def test_refusal_step_and_critical_step_read_differently(tmp_path):
    """six_dof's fem: a step 1e-7 above its critical step is refused with both
    numbers in as many digits as they need to differ."""
    from solver.model import layout as overlap
    from solver.model import arrays
    from solver.partitions import stability
    from solver.model.binding import from_dict
    raw = raw_scene("six_dof")
    scene = from_dict(raw)
    mdl = arrays.build(scene)
    lay = overlap.derive(mdl.graph(), scene.partitions, [1, 1])
    fr, crit, _ = stability.check(scene, scene.partitions[0], mdl, lay[0].held, lay[0].n_owned)
    raw["time"]["dt"] = crit * (1 + 1e-7) / scene.partitions[0].ratio
    raw["time"]["end"] = 10 * raw["time"]["dt"] * max(p.ratio for p in scene.partitions)
    line = refused(write_scene(tmp_path / "s.yaml", raw), [], tmp_path)
    step, critical = re.search(r"step (\S+) s \(ratio .* critical step (\S+) s", line).groups()
    assert step != critical and float(step) > float(critical), line
    assert float(critical) == pytest.approx(crit, rel=1e-7) and len(critical) <= 11


STIFF = ["model.lattice.E=7.0e11", "time.dt=1e-8", "time.end=1.2e-7"]


def test_transition_advice_is_the_rule_that_decides(tmp_path):
    """A 10x stiffer lattice at time.dt 1e-8 s: the DEM (damped by beta 2e-8 s)
    is unstable at that step whatever the FE ratio, so no ratio is advised (it
    was 'largest stable ratio 1', then refused too); at time.dt 2e-9 s the
    advised ratio runs and the next one is refused."""
    scene = ROOT / "configs" / "wave_bar_transition.yaml"
    line = refused(scene, STIFF, tmp_path)
    assert "partition 'fem': step 4e-08 s" in line
    assert ("fem critical step 1.826e-08 s (no stable ratio at time.dt 1e-08 s: partition 'dem' "
            "is unstable at it), dem critical step 3.187e-09 s") in line, line
    line = refused(scene, STIFF + ["partitions.fem.ratio=1"], tmp_path)
    assert line.startswith("error: partition 'dem': step 1e-08 s"), line
    small = ["model.lattice.E=7.0e11", "time.dt=2e-9", "partitions.fem.ratio=12"]
    line = refused(scene, small + ["time.end=1.2e-7"], tmp_path)
    ratio = int(re.search(r"largest stable ratio (\d+) at time.dt 2e-09 s", line).group(1))
    assert ratio == 9, line            # 1.829e-8 s / 2e-9 s
    refused(scene, small[:2] + [f"partitions.fem.ratio={ratio + 1}", "time.end=1.2e-7"], tmp_path)
    out = tmp_path / "ok.h5"
    sets = small[:2] + [f"partitions.fem.ratio={ratio}", f"time.end={2 * ratio * 2e-9}",
                        "reference=none"]
    proc = run_cli([scene, "--set", f"output.file={out}", *sum((["--set", s] for s in sets), [])])
    assert proc.returncode == 0, proc.stderr
    assert out.exists()


def test_stable_step_false_says_it_drops_the_damping_requirement(tmp_path):
    out = tmp_path / "x.h5"
    proc = run_cli([ROOT / "configs" / "wave_bar_transition.yaml", "--set", f"output.file={out}",
                    "--set", "damping.beta=0", "--set", "guard.stable_step=false",
                    "--set", "time.end=1.12e-7", "--set", "reference=none"])
    assert proc.returncode == 0, proc.stderr
    warning = [l for l in proc.stdout.splitlines() if "damping.beta: 0 s" in l]
    assert len(warning) == 1, proc.stdout
    assert "needs damping.beta >= 3.71e-10 s" in warning[0]
    assert warning[0].endswith("guard.stable_step is false: the transition scheme runs without "
                               "the damping it needs"), warning[0]


RANKS_SCRIPT = """
import sys
from solver.partitions import stability
stability.PREBUILD_LIMIT = 0          # every partition from its assembled operator
from solver.tools.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_assembled_estimate_is_the_same_on_1_and_2_ranks(tmp_path):
    """wave_bar_3d (9630 DOF, one partition split over both ranks): omega_max
    from the PETSc operator on 1 and 2 ranks and from the check before PETSc
    agree to 1e-8."""
    import os
    import subprocess
    script = tmp_path / "lowered.py"
    script.write_text(RANKS_SCRIPT)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    omegas = {}
    for label, cmd in (("before", [sys.executable, "-m", "solver"]),
                       ("1", [sys.executable, str(script)]),
                       ("2", [mpiexec(), "-n", "2", sys.executable, str(script)])):
        out = tmp_path / f"{label}.h5"
        proc = subprocess.run([*cmd, str(ROOT / "configs" / "wave_bar_3d.yaml"), "--set",
                               f"output.file={out}", "--set", "time.end=4e-8",
                               "--set", "reference=none"],
                              capture_output=True, text=True, env=env, timeout=300, cwd=ROOT)
        assert proc.returncode == 0, proc.stderr
        # MPICH's "yaksa: leaked handle" lines come from any split partition (not this)
        assert not [l for l in proc.stderr.splitlines() if "yaksa" not in l], proc.stderr
        if label == "2":
            assert "fem: ranks 0-1 (2)" in proc.stdout and "type mpibaij" in proc.stdout
        with h5py.File(out) as f:
            omegas[label] = float(f["partitions/fem"].attrs["omega_max"])
    assert omegas["before"] == pytest.approx(3.92e7, rel=1e-3)
    for label in ("1", "2"):
        assert omegas[label] == pytest.approx(omegas["before"], rel=1e-8), omegas
