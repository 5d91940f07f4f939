"""coupling.scheme conserving: the energy-conserving multi-time-step coupling
(solver/coupling/conserving.py, docs/conserving.md) on a 40-mass chain, seed
002's five-node chain and the FE wave_bar, against GC and the staggered scheme."""
import h5py
import numpy as np
import pytest

from conftest import (built, raw_scene, refused, run_cases, run_cli, run_scene, stop_and_restart,
                      write_scene)

N, SPLIT = 40, 20


def chain(m, dT=1.0, scheme="conserving", end=None, f_beta=0.0):
    """k = m = 1 chain with fixed ends: nodes 0-19 explicit at dT/m, 20-39
    implicit at dT; modes 1 and 3 displaced, released at rest."""
    x = np.arange(N)
    u0 = np.sin(np.pi * (x + 1) / (N + 1)) + 0.3 * np.sin(3 * np.pi * (x + 1) / (N + 1))
    springs = [["ground", 0, 1.0]] + [[i, i + 1, 1.0] for i in range(N - 1)] + \
        [[N - 1, "ground", 1.0]]
    return {
        "name": "chain40", "time": {"end": end or 300.0 * dT, "dt": dT / m},
        "model": {"kind": "network", "masses": [1.0] * N, "springs": springs},
        "partitions": [
            {"name": "fine", "method": "fem", "nodes": {"range": [0, SPLIT]},
             "integrator": "explicit", "beta": f_beta, "ratio": 1},
            {"name": "coarse", "method": "fem", "nodes": {"range": [SPLIT, N]},
             "integrator": "implicit", "ratio": m}],
        "coupling": {"scheme": scheme},
        "initial": {"displacement": {int(i): float(u) for i, u in enumerate(u0)}},
        "probes": [{"name": f"u{i}", "node": i} for i in (5, 19, 20, 30)],
        "reference": "modal",
    }


def invariant(scheme):
    """The conserved quantity: the fine side's energy half a fine step back
    (1/2 w.M w + 1/2 u_m.K u_m-1, w = v - h/2 a), the coarse side's energy, and
    1/2 h V . r_m (V the interface velocity, r_m the fine side's reaction)."""
    F, C = scheme.F, scheme.C
    h, n = F.dt, F.n_own
    w = F.V - 0.5 * h * F.A
    um1 = F.U - h * w
    K = F.Kneg                                       # -K
    Ku = K.createVecLeft()
    K.mult(F.u, Ku)
    e_f = 0.5 * np.dot(F.mass[:n], w[:n] ** 2) - 0.5 * np.dot(um1, Ku.getArray())
    Kc = C.Kneg
    Kuc = Kc.createVecLeft()
    Kc.mult(C.u, Kuc)
    e_c = 0.5 * np.dot(C.mass, C.V ** 2) - 0.5 * np.dot(C.U, Kuc.getArray())
    return e_f + e_c + 0.5 * h * np.dot(F.V[scheme.rf], scheme.r0)


@pytest.mark.parametrize("m, fine", [(2, "fem"), (4, "fem"), (8, "fem"), (20, "fem"), (100, "fem"),
                                     (4, "dem"), (20, "dem")])
def test_energy_is_conserved_at_any_ratio(m, fine, tmp_path):
    """10^5 fine steps of free vibration: the invariant holds to round-off, with
    a fem (central difference) or a dem (velocity Verlet) fine side."""
    raw = chain(m)
    if fine == "dem":
        raw["partitions"][0].update(method="dem", integrator="verlet")
        del raw["partitions"][0]["beta"]
    asm = built(raw, tmp_path)
    scheme = asm.scheme
    e0 = invariant(scheme)
    drift = 0.0
    for s in range(100_000 // m):
        scheme.step(s * 1.0)
        if s % 50 == 0:
            drift = max(drift, abs(invariant(scheme) - e0))
    drift = max(drift, abs(invariant(scheme) - e0))
    asm.destroy()
    assert drift < 1e-10 * e0, drift / e0


def test_spectral_radius_is_one_where_gc_grows(tmp_path):
    """One system step as a matrix at h = 0.9 x the fine side's critical step:
    the conserving scheme's spectral radius is 1 at m = 2, 4, 8; GC's exceeds 1
    at m = 2 (its slow growth on this chain is the method's: an independent
    re-implementation gives the same radius, docs/conserving.md)."""
    from solver.coupling.analysis import spectral_radius, step_matrix
    radii = {}
    for scheme, m in (("conserving", 2), ("conserving", 4), ("conserving", 8), ("gc", 2)):
        probe = built(chain(m, 1.0, scheme), tmp_path)
        crit = probe.scheme.freqs["fine"][1]
        probe.destroy()
        asm = built(chain(m, 0.9 * crit * m, scheme), tmp_path)
        radii[(scheme, m)] = spectral_radius(step_matrix(asm.scheme, asm.parts))
        asm.destroy()
    for m in (2, 4, 8):
        assert radii[("conserving", m)] < 1 + 1e-8, radii
    assert radii[("gc", 2)] > 1 + 1e-3, radii


def test_error_below_gc_at_every_ratio_and_second_order(tmp_path):
    """Against the exact modal solution at coarse step 1 s (t = 300 s): the
    conserving scheme's error is below GC's at m = 2, 4, 8, 20; halving the
    coarse step (m = 4) divides it by about 4."""
    errors = {}
    for m in (2, 4, 8, 20):
        for scheme in ("conserving", "gc"):
            res = run_scene(chain(m, scheme=scheme, end=300.0), tmp_path)
            errors[(scheme, m)] = res.attrs["vector_rel_error"]
    for m in (2, 4, 8, 20):
        assert 3 * errors[("conserving", m)] < errors[("gc", m)], errors
    fine = [run_scene(chain(4, dT, end=150.0), tmp_path).attrs["vector_rel_error"]
            for dT in (1.0, 0.5, 0.25)]
    order = np.polyfit(np.log([1.0, 0.5, 0.25]), np.log(fine), 1)[0]
    assert 1.8 < order < 2.3, (order, fine)


def test_five_node_matches_staggered_and_beats_gc(tmp_path):
    raw = raw_scene("five_node")
    raw["partitions"][0]["beta"] = 0.0
    out = {}
    for scheme in ("conserving", "staggered", "gc"):
        raw["coupling"] = {"scheme": scheme}
        out[scheme] = run_scene(raw, tmp_path).attrs["vector_rel_error"]
    assert out["conserving"] < 1e-7 and out["conserving"] < 1.5 * out["staggered"], out
    assert 100 * out["conserving"] < out["gc"], out


def test_wave_bar_at_eta_10(tmp_path):
    """The FE bar, fine middle region explicit, the rest implicit at 10 x the
    step (4 x its own explicit limit): arrival within 1 %, peak within 5 %."""
    raw = raw_scene("wave_bar_mts")
    res = run_scene(raw, tmp_path)
    for name in ("A", "B", "C"):
        attrs = res.probes[name]["attrs"]
        assert abs(attrs["stress_arrival_error"]) < 0.01 and abs(attrs["stress_peak_error"]) < 0.05, attrs


def test_wave_bar_with_its_lattice_at_eta_10(tmp_path):
    """Zhang et al.'s (2009) bar with the bonded-lattice middle (dem, velocity Verlet) and
    the FE rest implicit at 10 x the step (5.4 x the explicit limit, where the
    staggered scheme blows up): arrival within 1 %, peak within 5 %, and no
    warning about the implicit step's ratio (stable by construction)."""
    proc = run_cli(["configs/wave_bar.yaml", "--set", "coupling.scheme=conserving",
                    "--set", "partitions.fem.integrator=implicit", "--set", "partitions.fem.ratio=10",
                    "--set", f"output.file={tmp_path / 'w.h5'}"], timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in proc.stdout + proc.stderr
    assert "fine 'dem'" in proc.stdout and "stable by construction" in proc.stdout
    with h5py.File(tmp_path / "w.h5") as f:
        for name in "ABC":
            attrs = f[f"probes/{name}"].attrs
            assert abs(attrs["stress_arrival_error"]) < 0.01, (name, dict(attrs))
            assert abs(attrs["stress_peak_error"]) < 0.05, (name, dict(attrs))


@pytest.mark.parametrize("scene,sets,key", [
    ("wave_bar_mts", ["partitions.fine.beta=0.25"], "partitions[0].beta"),
    ("wave_bar_mts", ["partitions.coarse.beta=0.3"], "partitions[1].beta"),
    ("wave_bar_mts", ["partitions.coarse.integrator=explicit"], "coupling.scheme"),
    ("wave_bar", ["coupling.scheme=conserving"], "coupling.scheme"),
    ("metamaterial_implicit", ["coupling.scheme=conserving", "partitions.dem.method=fem",
                               "partitions.dem.integrator=implicit"], "coupling.scheme"),
])
def test_bad_layouts_are_refused(scene, sets, key, tmp_path):
    line = refused(f"configs/{scene}.yaml", sets, tmp_path)
    assert f".yaml: {key}: " in line, line


def test_loads_on_the_fine_side(tmp_path):
    """A half-sine on a fine node (node 3) of the chain at m = 4: the error
    against the exact modal response is as small as the staggered scheme's;
    the external work, tracked on the true fine path, is the exact work
    (the integral of f v with the modal velocity) to 1 %; after the load the
    invariant holds to 1e-10."""
    from solver.driver import reference
    from solver.model import arrays
    from solver.model.binding import from_dict
    out = {}
    for scheme in ("conserving", "staggered"):
        raw = chain(4, scheme=scheme, end=100.0)
        raw["initial"] = {}
        raw["loads"] = [{"node": 3, "kind": "half_sine", "amplitude": 0.2, "duration": 5.0}]
        res = run_scene(raw, tmp_path)
        out[scheme] = res.attrs["vector_rel_error"]
    t = np.linspace(0.0, 5.0, 5001)
    _, v = reference.modal(arrays.build(from_dict(raw)), [3], t)
    f = 0.2 * np.sin(np.pi * t / 5.0)
    exact = float(np.sum(0.5 * (f[1:] * v[1:, 0] + f[:-1] * v[:-1, 0]) * np.diff(t)))
    raw = chain(4, end=100.0)
    raw["initial"] = {}
    raw["loads"] = [{"node": 3, "kind": "half_sine", "amplitude": 0.2, "duration": 5.0}]
    asm = built(raw, tmp_path)
    scheme = asm.scheme
    for s in range(6):
        scheme.step(float(s))
    e6 = invariant(scheme)
    for s in range(6, 100):
        scheme.step(float(s))
    assert abs(invariant(scheme) - e6) < 1e-10 * e6
    assert scheme.F.work == pytest.approx(exact, rel=1e-2), (scheme.F.work, exact)
    asm.destroy()
    assert out["conserving"] < 1.05 * out["staggered"], out       # (the coarse step limits both)


def histories(path):
    with h5py.File(path) as f:
        return {k: f[f"probes/{k}/displacement"][()] for k in f["probes"]}, f.attrs["ranks"]


TWO_RANK_CASES = [
    ("chain", []),
    ("wave_bar_mts", ["time.end=1.6e-5", "partitions.coarse.ratio=10"]),
    ("wave_bar_mts", ["time.end=1.6e-5", "partitions.coarse.ratio=10", "partitions.0.ranks=1",
                      "partitions.1.ranks=1"]),
    ("wave_bar", ["time.end=1.6e-5", "coupling.scheme=conserving", "partitions.fem.ratio=10",
                  "partitions.fem.integrator=implicit"]),
]


@pytest.fixture(scope="module")
def two_rank_runs(tmp_path_factory):
    """Every case of TWO_RANK_CASES on 1 rank and on 2: one launch per rank count
    (tests/mpi/cli_cases.py); the output of case i on n ranks is c{i}_n{n}.h5."""
    tmp = tmp_path_factory.mktemp("two_ranks")
    cases = {1: [], 2: []}
    for i, (scene, sets) in enumerate(TWO_RANK_CASES):
        raw = chain(8, end=60.0) if scene == "chain" else raw_scene(scene)
        if scene == "chain":
            raw["partitions"].reverse()
        for n in cases:
            raw["output"] = {"file": str(tmp / f"c{i}_n{n}.h5")}
            cases[n].append([write_scene(tmp / f"c{i}_s{n}.yaml", raw),
                             *sum((["--set", x] for x in sets), [])])
    for n, argvs in cases.items():
        proc = run_cases(argvs, tmp, n=n if n > 1 else None, timeout=300)
        assert proc.returncode == 0, proc.stderr
    return tmp


@pytest.mark.parametrize("case", range(len(TWO_RANK_CASES)),
                         ids=[f"{s}-sets{i}" for i, (s, _) in enumerate(TWO_RANK_CASES)])
def test_two_ranks_match_one_rank(case, two_rank_runs):
    """Each side on its own rank (one allreduce per system step) gives the
    one-rank run to 1e-10 of the largest displacement; on the chain the two
    sides are swapped in the partition list too."""
    out = {}
    for n in (1, 2):
        out[n] = histories(two_rank_runs / f"c{case}_n{n}.h5")
        assert out[n][1] == n
    scale = max(np.abs(h).max() for h in out[1][0].values())
    assert scale > 0
    for k, one in out[1][0].items():
        assert np.abs(one - out[2][0][k]).max() <= 1e-10 * scale, k


def test_restart_on_two_ranks_continues_the_run(tmp_path):
    """A run stopped at t = 30 s (a load on the interface node still acting) and
    restarted on 2 ranks ends where the uninterrupted 1-rank run ends: the
    interface force is recovered from the coarse side's state and loads at the
    restart time."""
    raw = chain(4, end=60.0)
    raw["loads"] = [{"node": SPLIT, "kind": "half_sine", "amplitude": 0.5, "duration": 50.0}]
    raw["reference"] = "none"
    whole, short = stop_and_restart(raw, tmp_path, 60.0, 30.0, 10, n=2)
    with h5py.File(whole) as a, h5py.File(short) as b:
        assert b.attrs["ranks"] == 2 and b.attrs["status"] == "completed"
        for k in ("u5", "u20", "u30"):
            x, y = a[f"probes/{k}/displacement"][()], b[f"probes/{k}/displacement"][()]
            assert x.shape == y.shape and np.abs(x).max() > 0.1
            assert np.abs(x - y).max() <= 1e-10 * np.abs(x).max(), k


def test_strain_energy_of_both_sides_is_the_whole_chains(tmp_path):
    """The fine side counts its elements' energy on the interface rows it does
    not own (Partition.n_energy): fine + coarse strain energy is 1/2 u.K u of
    the whole chain for any state."""
    asm = built(chain(4), tmp_path)
    scheme, rng = asm.scheme, np.random.default_rng(3)
    u = rng.standard_normal(N)
    for part in scheme.parts:
        part.U[:part.n_own] = u[part.layout.owned]
    scheme.synchronise()
    strain = sum(part.energies()[1] for part in scheme.parts)
    ext = np.concatenate([[0.0], u, [0.0]])                 # fixed ends: springs to the ground
    exact = 0.5 * float(np.sum(np.diff(ext) ** 2))
    asm.destroy()
    assert strain == pytest.approx(exact, rel=1e-12)


def small_bar():
    """wave_bar_mts at 0.8 mm cells (1,604 nodes) with its explicit region
    [8, 16] mm near the loaded end, so the pulse enters it within 8 system
    steps (coarse ratio 4); probes in and beside the region."""
    raw = raw_scene("wave_bar_mts")
    raw["model"]["mesh_parameters"] = {"a": 0.0008, "x1": 0.008, "x2": 0.016}
    raw["time"] = {"end": 8 * 4 * 8e-8, "dt": 8e-8}
    raw["partitions"][1]["ratio"] = 4
    raw["probes"] = [{"name": n, "at": [x, 0.0012]} for n, x in (("A", 0.004), ("B", 0.012),
                                                                   ("C", 0.024))]
    raw["reference"] = "none"
    return raw


def loaded_dem_chain():
    """The chain at m = 4 with a dem (velocity Verlet) fine side and a half-sine
    on fine node 3: the fine side's load work is tracked on each of its ranks."""
    raw = chain(4, end=12.0)
    raw["partitions"][0].update(method="dem", integrator="verlet")
    del raw["partitions"][0]["beta"]
    raw["loads"] = [{"node": 3, "kind": "half_sine", "amplitude": 0.2, "duration": 5.0}]
    return raw


N_RANKS = (1, 2, 3, 4)
# scene, and the partitions[].ranks (fine, coarse) on 3 and 4 ranks (None: by cost);
# a coarse side on several ranks solves iteratively (CG + GAMG, rtol 1e-12)
N_RANK_CASES = [
    ("chain", {3: None, 4: (2, 2)}),
    ("loaded_dem_chain", {3: (1, 2), 4: (3, 1)}),
    ("small_bar", {3: (2, 1), 4: (2, 2)}),
]
BY_COST_ON_3 = (2, 1)                   # the chain's fine side costs 8 x the coarse one


@pytest.fixture(scope="module")
def n_rank_runs(tmp_path_factory):
    """Every case of N_RANK_CASES on 1, 2, 3 and 4 ranks, one launch per rank
    count (tests/mpi/cli_cases.py), each with its final state (checkpoint) and
    energies every system step: c{i}_n{n}.h5, its log c{i}_n{n}.log."""
    tmp = tmp_path_factory.mktemp("n_ranks")
    scenes = {"chain": lambda: chain(8, end=10.0), "loaded_dem_chain": loaded_dem_chain,
              "small_bar": small_bar}
    for n in N_RANKS:
        argvs = []
        for i, (scene, given) in enumerate(N_RANK_CASES):
            raw = scenes[scene]()
            raw["output"] = {"file": str(tmp / f"c{i}_n{n}.h5"), "energy_every": 1,
                             "checkpoint": {"every": 1000}, "progress": 0}
            sets = []
            if given.get(n):
                sets = [f"partitions.{k}.ranks={r}" for k, r in enumerate(given[n])]
            argvs.append(([write_scene(tmp / f"c{i}_s{n}.yaml", raw),
                           *sum((["--set", x] for x in sets), [])], tmp / f"c{i}_n{n}.log"))
        proc = run_cases(argvs, tmp, n=n if n > 1 else None, timeout=120)
        assert proc.returncode == 0, proc.stderr
    return tmp


def final_state(path):
    """(probe histories, energies, final owned states per partition, the scheme's
    checkpoint memory, ranks) of an output file."""
    with h5py.File(path) as f:
        g = f["checkpoint"]
        parts = {k: (g[f"partitions/{k}/nodes"][()], g[f"partitions/{k}/uva"][()])
                 for k in g["partitions"]}
        memory = {k: g[f"scheme/{k}"][()] for k in g["scheme"]}
        return ({k: f[f"probes/{k}/displacement"][()] for k in f["probes"]},
                f["energy/total"][()], parts, memory, f.attrs["ranks"])


@pytest.mark.parametrize("case", range(len(N_RANK_CASES)),
                         ids=[s for s, _ in N_RANK_CASES])
def test_each_side_on_several_ranks_matches_one_rank(case, n_rank_runs):
    """Each side split over its own ranks: on 2 ranks (one per side) the 1-rank
    run to the last bit; with the fine side split (explicit) to 1e-12 of the
    largest value, with the coarse side split (CG + GAMG at rtol 1e-12) to
    1e-8: probes, the final state of every node, the interface memory of the
    checkpoint, and the energy (so its drift is the 1-rank run's)."""
    scene, given = N_RANK_CASES[case]
    one = final_state(n_rank_runs / f"c{case}_n1.h5")
    energy = one[1]
    e_scale = np.abs(energy).max()                  # (the bar starts at rest: E(0) = 0)
    assert np.abs(energy - energy[0]).max() > 0 and e_scale > 0
    for n in N_RANKS[1:]:
        probes, total, parts, memory, ranks = final_state(n_rank_runs / f"c{case}_n{n}.h5")
        assert ranks == n
        log = (n_rank_runs / f"c{case}_n{n}.log").read_text()
        fine, coarse = (1, 1) if n == 2 else given[n] or BY_COST_ON_3
        assert f"sides on {fine} + {coarse} rank(s)" in log, log
        assert ("iterative, KSP cg + PC gamg" in log) == (coarse > 1), log
        tol = 0.0 if n == 2 else 1e-8 if coarse > 1 else 1e-12
        for k, h in one[0].items():
            assert np.abs(probes[k] - h).max() <= tol * np.abs(h).max(), (n, k)
        for name, (nodes, uva) in one[2].items():
            assert np.array_equal(parts[name][0], nodes)
            for row in range(3):               # u, v, a each against its own scale
                scale = np.abs(uva[row]).max()
                assert scale > 0 and np.abs(parts[name][1][row] - uva[row]).max() <= tol * scale, \
                    (n, name, row)
        for key, value in one[3].items():
            assert np.abs(memory[key] - value).max() <= tol * np.abs(value).max(), (n, key)
        drift_1, drift_n = np.abs(energy - energy[0]).max(), np.abs(total - total[0]).max()
        assert abs(drift_n - drift_1) <= max(tol, 1e-12) * e_scale, (n, drift_1, drift_n)
        assert np.abs(total - energy).max() <= max(tol, 1e-12) * e_scale, n


def test_partition_ranks_that_do_not_fit_are_refused(tmp_path):
    """partitions[].ranks that do not add up to the launch: one line, exit 4,
    no output file."""
    raw = chain(4)
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    raw["partitions"][0]["ranks"] = 2
    raw["partitions"][1]["ranks"] = 2
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)], n=3)
    line, = proc.stderr.strip().splitlines()
    assert proc.returncode == 4 and "partitions[].ranks add up to 4" in line, proc.stderr
    assert not (tmp_path / "o.h5").exists()
