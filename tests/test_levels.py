"""partitions: auto, time.dt: auto and time.mass_scaling (solver/partitions/levels.py,
solver/partitions/subcycling.py, solver/model/element_bounds.py, docs/guide/levels.md)."""
import copy

import h5py
import numpy as np
import pytest

from conftest import ROOT, raw_scene, refused, run_cases, run_scene, write_scene

GROUPS = (1.0, 4.0, 16.0, 64.0)         # node masses of the chain's four stretches
PER = 10


def chain(dt=0.25, end=50.0, u0=True):
    """k = 1 chain of 40 masses, fixed to the ground at both ends, the masses
    1, 4, 16, 64 in stretches of 10: interior springs' bounds (1/degree mass
    shares) are sqrt(m) = 1, 2, 4, 8 s."""
    n = PER * len(GROUPS)
    masses = [m for m in GROUPS for _ in range(PER)]
    springs = [["ground", 0, 1.0]] + [[i, i + 1, 1.0] for i in range(n - 1)] + \
        [[n - 1, "ground", 1.0]]
    x = np.arange(n)
    raw = {"name": "chain", "time": {"end": end, "dt": dt},
           "model": {"kind": "network", "masses": masses, "springs": springs},
           "partitions": "auto",
           "probes": [{"name": f"u{i}", "node": i} for i in (0, 15, 25, 39)]}
    if u0:
        shape = np.sin(np.pi * (x + 1) / (n + 1)) + 0.5 * np.sin(7 * np.pi * (x + 1) / (n + 1))
        raw["initial"] = {"displacement": {int(i): float(u) for i, u in enumerate(shape)}}
    return raw


def resolved(raw):
    """(resolved scene, rank 0's model) of raw scene data on this process."""
    from mpi4py import MPI

    from solver.driver.build import resolve
    from solver.model import binding
    from solver.petscutil import init
    init([])
    return resolve(binding.from_dict(copy.deepcopy(raw)), MPI.COMM_SELF)


def built(raw, tmp_path):
    from mpi4py import MPI

    from solver.driver.build import build
    from solver.model import binding
    from solver.petscutil import init
    init([])
    raw = dict(copy.deepcopy(raw), output={"file": str(tmp_path / "b.h5")})
    return build(binding.from_dict(raw), MPI.COMM_SELF)


def test_levels_follow_the_element_bounds():
    """Every element on the largest power-of-two ratio r with r dt <= 0.9 x its
    bound (the bound: the spring's closed form with 1/degree mass shares),
    then two buffer layers: every element takes the smallest ratio at its
    nodes, twice.  The chain's stretches keep ratios 1, 2, 4, 8 inside."""
    from solver.model import element_bounds
    from solver.partitions import levels as lv
    scene, mdl = resolved(chain(dt=0.5, end=48.0))
    part, = scene.partitions
    assert (part.integrator, part.ratio) == ("levels", 8)
    assert part.levels.ratios == (1, 2, 4, 8)
    bounds = element_bounds.model_bounds(scene, mdl)
    raw = lv.assign(bounds, 0.5, np.array([1, 2, 4, 8]), 0.9, buffer=0)
    for b, r in zip(bounds, raw):
        assert np.all(r * 0.5 <= 0.9 * b.steps + 1e-15)
        assert np.all((2 * r * 0.5 > 0.9 * b.steps) | (r == 8))
    inner = np.array([[i, i + 1] for i in range(39)])
    m = np.array(GROUPS)[inner // PER]                    # both ends' masses
    bound = 2 / np.sqrt(2 / m[:, 0] + 2 / m[:, 1])        # sqrt(m) within a stretch
    want = (2 ** np.floor(np.log2(0.9 * bound / 0.5)).clip(0, 3)).astype(int)
    pairs = next(b for b in bounds if b.conn.shape[1] == 2)
    assert np.allclose(pairs.steps, bound)
    assert np.array_equal(raw[bounds.index(pairs)], want)
    for _ in range(2):                                    # the buffer, by hand on the chain
        node = np.minimum(np.r_[want[0], want], np.r_[want, want[-1]])
        want = np.minimum(node[:-1], node[1:])
    assert np.array_equal(part.levels.lookup(inner), want)
    assert [int(want[k * PER + 5]) for k in range(4)] == [1, 2, 4, 8]


def test_auto_dt_is_the_finest_levels_critical_step():
    """time.dt: auto: 0.9 x the critical step of the finest level's operator
    (exact here: a 2x2 eigenvalue problem per stretch), lowered to divide end."""
    raw = chain(dt="auto", end=64.0)
    scene, mdl = resolved(raw)
    h = scene.time.dt
    R = scene.partitions[0].ratio
    assert abs(64.0 / (R * h) - round(64.0 / (R * h))) < 1e-9
    # the finest level's elements: their operator's critical step
    from solver.partitions import levels as lv
    from solver.model import element_bounds
    from solver.model.arrays import dof_masses
    bounds = element_bounds.model_bounds(scene, mdl)
    per = [scene.partitions[0].levels.lookup(b.conn) for b in bounds]
    omega = lv.level_omega(mdl, bounds, per, 1, dof_masses(mdl, np.arange(mdl.n_nodes)))
    assert h <= 0.9 * 2 / omega * (1 + 1e-12)
    assert h > 0.9 * 2 / omega / 1.05          # lowered by less than the rounding to whole steps


def energy(part):
    K = part.Kneg
    Ku = K.createVecLeft()
    K.mult(part.u, Ku)
    e = 0.5 * np.dot(part.mass, part.V ** 2) - 0.5 * np.dot(part.U, Ku.getArray())
    Ku.destroy()
    return e


def test_energy_does_not_drift_over_1e5_fine_steps(tmp_path):
    """Free vibration on four levels (ratios 1-8), 10^5 fine steps at 0.9 x
    the finest bound: the energy stays in its band (the symplectic map's
    modified energy is conserved); its mean over the last tenth equals the
    first tenth's to 1e-4."""
    asm = built(chain(dt=0.9 * 1.0 / 1.0, end=0.9 * 8), tmp_path)
    part, = asm.parts
    R = part.spec.ratio
    e0 = energy(part)
    es = []
    for s in range(100_000 // R):
        asm.scheme.step(s * part.dt)
        es.append(energy(part))
    asm.destroy()
    es = np.array(es)
    tenth = es.size // 10
    assert np.max(np.abs(es - e0)) < 0.25 * e0, np.max(np.abs(es - e0)) / e0
    drift = abs(es[-tenth:].mean() - es[:tenth].mean()) / e0
    assert drift < 1e-4, drift


def test_step_map_spectral_radius_is_one(tmp_path):
    """One system step as a matrix (solver/coupling/analysis.py): eigenvalues on
    the unit circle (radius 1 to 1e-10) at 0.3, 0.6 and 0.9 x the finest
    bound; the overlap scheme on the same chain cut by hand into the same four
    levels is not stable (radius above 1)."""
    from solver.coupling import analysis
    for f in (0.3, 0.6, 0.9):
        asm = built(chain(dt=f, end=8 * f, u0=False), tmp_path)
        G = analysis.step_matrix(asm.scheme, asm.parts)
        rho = analysis.spectral_radius(G)
        asm.destroy()
        assert abs(rho - 1.0) < 1e-10, (f, rho)
    raw = chain(dt=0.9, end=8 * 0.9, u0=False)
    raw["partitions"] = [{"name": f"l{r}", "method": "fem", "integrator": "explicit", "beta": 0.0,
                          "ratio": r, "nodes": {"range": [k * PER, (k + 1) * PER]}}
                         for k, r in enumerate((1, 2, 4, 8))]
    raw["guard"] = {"stable_step": False}      # each side's own step is near its limit
    asm = built(raw, tmp_path)
    rho = analysis.spectral_radius(analysis.step_matrix(asm.scheme, asm.parts))
    asm.destroy()
    assert rho > 1.0 + 1e-6, rho


PLATE = {"mesh_parameters": {"L": 0.2, "W": 0.1, "r": 0.01, "h_min": 0.001, "h_max": 0.016,
                             "d": 0.06}}


def plate(end=2.0e-5, **time):
    raw = raw_scene("plate_hole")
    raw["model"].update(PLATE)
    raw["time"] = {"end": end, **({"dt": "auto"} | time)}
    raw["probes"] = [{"name": "edge", "at": [0.2, 0.05]}, {"name": "hole", "at": [0.111, 0.05]}]
    return raw


def test_uniform_mesh_is_one_level_and_the_uniform_run(tmp_path):
    """A structured plate: one level, the plain explicit partition, and the run
    is the hand-written one bit for bit."""
    raw = raw_scene("wave_bar_fem")
    raw["time"] = {"end": 4.0e-6, "dt": "auto"}
    del raw["reference"]
    auto = dict(copy.deepcopy(raw), partitions="auto")
    scene, _ = resolved(auto)
    part, = scene.partitions
    assert (part.integrator, part.ratio, part.beta) == ("explicit", 1, 0.0)
    raw["partitions"][0]["beta"] = 0.0
    raw["time"]["dt"] = scene.time.dt
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = run_scene(auto, tmp_path / "a")
    b = run_scene(raw, tmp_path / "b")
    for name in ("A", "B", "C"):
        for field in ("displacement", "velocity"):
            assert np.array_equal(a.probes[name][field], b.probes[name][field])


def test_graded_plate_runs_levelled_and_matches_the_uniform_step(tmp_path):
    """The plate with a refined hole: several levels, the run's probes within
    1 % of the uniform run at the finest level's step (the same dt)."""
    raw = plate(end=3.0e-5)
    scene, _ = resolved(raw)
    part, = scene.partitions
    assert part.integrator == "levels" and len(part.levels.ratios) >= 3
    a = run_scene(raw, tmp_path)
    uni = copy.deepcopy(raw)
    uni["time"]["dt"] = scene.time.dt
    uni["partitions"] = [{"name": "fem", "method": "fem", "group": "solid",
                          "integrator": "explicit", "beta": 0.0, "ratio": 1}]
    (tmp_path / "u").mkdir()
    b = run_scene(uni, tmp_path / "u")
    ua, ub = a.probes["edge"]["displacement"], b.probes["edge"]["displacement"]
    step = part.ratio
    assert np.max(np.abs(ua - ub[::step][:ua.size])) < 0.01 * np.max(np.abs(ub))


def test_mass_scaling_adds_mass_only_below_the_target():
    """Only the elements whose bound is below the target get mass, each exactly
    enough to reach it; the total is what the report says."""
    from solver.model import element_bounds
    raw = plate()
    plain, mdl0 = resolved(raw)
    bounds = element_bounds.model_bounds(plain, mdl0)
    smallest = min(b.steps.min() for b in bounds)
    target = 1.5 * smallest
    raw["time"]["mass_scaling"] = {"dt": float(target)}
    scene, mdl = resolved(raw)
    low = np.zeros(mdl0.n_nodes, bool)
    expect = np.zeros(mdl0.n_nodes)
    for b in bounds:
        below = b.steps < target
        low[b.conn[below].ravel()] = True
        extra = b.own[below][:, :, 0] * ((target / b.steps[below]) ** 2 - 1)[:, None]
        expect += np.bincount(b.conn[below].ravel(), extra.ravel(), minlength=mdl0.n_nodes)
    added = mdl.mass - mdl0.mass
    assert np.all(added[~low] == 0) and np.all(added[low] > 0)
    assert np.allclose(added, expect, rtol=1e-12, atol=0)
    scaling = scene.partitions[0].levels.scaling
    assert np.isclose(scaling.added, added.sum(), rtol=1e-12)
    assert scaling.elements == sum(int((b.steps < target).sum()) for b in bounds)


def test_auto_levels_agree_on_1_2_and_4_ranks(tmp_path):
    """The levelled plate on 1, 2 and 4 ranks: probe histories equal to 1e-12."""
    raw = plate(end=2.0e-5)
    path = write_scene(tmp_path / "p.yaml", raw)
    outs = {}
    for n in (1, 2, 4):
        outs[n] = tmp_path / f"p{n}.h5"
        proc = run_cases([[path, "--set", f"output.file={outs[n]}", "--set", "output.progress=0"]],
                         tmp_path, n=n, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
    with h5py.File(outs[1]) as f1:
        ref = {k: f1["probes"][k]["displacement"][()] for k in f1["probes"]}
    scale = max(np.abs(v).max() for v in ref.values())
    for n in (2, 4):
        with h5py.File(outs[n]) as f:
            for k, v in ref.items():
                assert np.max(np.abs(f["probes"][k]["displacement"][()] - v)) <= 1e-12 * scale, \
                    (n, k)


@pytest.mark.parametrize("sets, key", [
    (["coupling.scheme=conserving"], "coupling.scheme"),
    (["time.levels.max_ratio=3"], "time.levels.max_ratio"),
    (["time.levels.max_ratio=0"], "time.levels.max_ratio"),
    (["time.levels.max_ratio=2.5"], "time.levels.max_ratio"),
    (["time.safety=1.5"], "time.safety"),
    (["time.mass_scaling.dt=1.0"], "time.mass_scaling.dt"),
    (["time.mass_scaling.dt=1e-12"], "time.mass_scaling.dt"),
    (["damping.alpha=10.0"], "damping"),
])
def test_bad_auto_input_is_one_line(sets, key, tmp_path):
    path = write_scene(tmp_path / "p.yaml", plate())
    line = refused(path, sets, tmp_path)
    assert key in line and line.startswith("error:"), line


def test_auto_needs_a_levelled_model(tmp_path):
    """dt: auto with hand-written partitions, auto on a lattice: one line."""
    line = refused(ROOT / "configs" / "wave_bar_fem.yaml", ["time.dt=auto"], tmp_path)
    assert "time.dt" in line
    line = refused(ROOT / "configs" / "bar3d.yaml", ["partitions=auto"], tmp_path)
    assert "partitions" in line and "lattice" in line


def test_integer_ratios_divide_the_system_step():
    """ratios: integers (divisors of max_ratio 12): every ratio present divides
    the largest present, so every level closes every system step."""
    raw = chain(dt=0.5, end=48.0)
    raw["time"]["levels"] = {"ratios": "integers", "max_ratio": 12}
    scene, _ = resolved(raw)
    part, = scene.partitions
    R = part.ratio
    assert len(part.levels.ratios) >= 3 and all(R % r == 0 for r in part.levels.ratios)
    assert 48.0 / (R * 0.5) == round(48.0 / (R * 0.5))


def test_levelled_run_restarts_bitwise(tmp_path):
    """A levelled plate stopped at a checkpoint and restarted ends bitwise equal
    to the uninterrupted run."""
    from conftest import stop_and_restart
    raw = plate(end=2.0e-5)
    raw["time"]["dt"] = 1.25e-7          # given: the step does not depend on the end
    whole, short = stop_and_restart(raw, tmp_path, end=2.0e-5, stop=1.0e-5, every=4)
    with h5py.File(whole) as a, h5py.File(short) as b:
        for k in a["probes"]:
            assert np.array_equal(a["probes"][k]["displacement"][()],
                                  b["probes"][k]["displacement"][()]), k


def test_plan_lists_the_candidates_with_their_steps(tmp_path):
    """./run.sh plan on the graded chain: the uniform step is 0.9 x the exact
    critical step of the whole chain (Lanczos: within 0.3 %), the levels row
    has ratios 1-8 at the scene's time.dt; networks get no mass scaling."""
    import re
    from conftest import run_cli
    raw = chain(dt=0.5, end=48.0)
    proc = run_cli(["plan", write_scene(tmp_path / "c.yaml", raw)])
    assert proc.returncode == 0, proc.stderr
    rows = {line.split("|")[1].strip(): line.split("|")[2:] for line in proc.stdout.splitlines()
            if line.startswith("| ") and not line.startswith("| candidate")}
    assert set(rows) == {"uniform explicit", "automatic levels"}
    n = PER * len(GROUPS)
    K = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    m = np.repeat(GROUPS, PER)
    omega = np.sqrt(np.linalg.eigvalsh(K / np.sqrt(np.outer(m, m)))[-1])
    dt = float(rows["uniform explicit"][0])
    assert 0.9 * 2 / omega * 0.997 <= dt <= 0.9 * 2 / omega * 1.0001
    assert rows["automatic levels"][1].strip() == "1, 2, 4, 8"
    assert float(rows["automatic levels"][0]) == 0.5        # the scene's own time.dt
    assert float(rows["automatic levels"][-2]) > 0
    assert re.search(r"ns per MatMult nonzero", proc.stdout)


@pytest.mark.parametrize("scene", ["plate_fracture", "brazilian_disc"])
def test_plan_refuses_a_lattice_scene_in_one_line(scene):
    """./run.sh plan on a scene with a bonded lattice (regular or random): one
    line naming model.lattice, exit 2 (it used to fail on the lattice's
    particles, which no levelled partition owns)."""
    from conftest import ROOT, run_cli
    proc = run_cli(["plan", ROOT / "configs" / f"{scene}.yaml"])
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert line.startswith("error: model.lattice: plan predicts the levels"), line


def test_an_unstable_level_is_refused_naming_its_critical_step(tmp_path):
    """A time.dt beyond the finest level's critical step: one line naming the
    level and its critical step, before stepping; guard.stable_step false runs
    anyway with the warning in the log."""
    path = write_scene(tmp_path / "p.yaml", plate(end=2.0e-5, dt=2.0e-7))
    line = refused(path, [], tmp_path)
    assert "level 1 steps 2e-07 s, beyond its critical step" in line, line
    from conftest import run_cli
    out = tmp_path / "anyway.h5"
    proc = run_cli([path, "--set", f"output.file={out}", "--set", "guard.stable_step=false",
                    "--set", "time.end=4.0e-7"])
    assert "guard.stable_step is false: running anyway" in proc.stdout + proc.stderr
    assert out.exists()
