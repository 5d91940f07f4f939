"""The log users read and the docs that say what exists.

- Set-up prints the model's total mass, its wave speeds and each partition's
  elements with the smallest estimated steps (solver/model/element_steps.py);
  the progress line carries the energy guard's latest sample.
- The figures the README and docs quote from benchmark pages are in those
  pages' generated tables (benchmarks/tables.py), copied tables match their
  source, and user docs cite the papers, not seed file numbers.
- A 3-rank run leaves no MPI handles behind (MPICH's yaksa "leaked" warnings).
"""
from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import pytest

from conftest import ROOT, raw_scene, run_cli, write_scene

sys.path.insert(0, str(ROOT / "benchmarks"))
import tables  # noqa: E402


def setup_lines(raw, tmp_path, lines=None):
    """The set-up log of a scene's build on this process (into ``lines``)."""
    from mpi4py import MPI

    from solver import scene as scene_mod
    from solver.driver.build import build
    from solver.model import binding
    from solver.petscutil import init
    init([])
    raw = dict(raw, output={"file": str(tmp_path / "b.h5")})
    lines = [] if lines is None else lines
    asm = build(binding.bind(scene_mod.from_dict(raw)), MPI.COMM_SELF, lines.append)
    asm.destroy()
    return lines


def figure(lines, pattern):
    """The first float that ``pattern`` captures in the log lines."""
    for line in lines:
        m = re.search(pattern, line)
        if m:
            return float(m[1])
    raise AssertionError(f"{pattern!r} not in the log:\n" + "\n".join(lines))


def digits(x: float, sig: int) -> float:
    return float(f"{x:.{sig}g}")


def test_setup_prints_the_mass_wave_speeds_and_smallest_cell_steps_of_a_plane_stress_bar(tmp_path):
    """wave_bar_fem: 0.32 m x 2.4 mm x 0.32 mm of rho 2700 weighs rho V; plane
    stress: plate speed sqrt(E/(rho (1 - nu^2))), s wave sqrt(G/rho), bar
    sqrt(E/rho) = 5092 m/s; its 1 x 0.6 mm quads have L = 0.6 mm."""
    lines = setup_lines(raw_scene("wave_bar_fem"), tmp_path)
    E, nu, rho = 70.0e9, 0.33, 2700.0
    assert figure(lines, r"total mass (\S+) kg") == digits(rho * 0.32 * 0.0024 * 3.2e-4, 6)
    plate = math.sqrt(E / (rho * (1 - nu ** 2)))
    assert figure(lines, r"plate (\S+) m/s") == digits(plate, 5)
    assert figure(lines, r"s wave (\S+) m/s") == digits(math.sqrt(E / (2 * (1 + nu)) / rho), 5)
    assert figure(lines, r"bar sqrt\(E/rho\) (\S+) m/s") == digits(math.sqrt(E / rho), 5) == 5091.8
    assert figure(lines, r"fem: smallest element steps .*?: (\S+) s quad4 cell") == \
        digits(0.6e-3 / plate, 4)
    line = next(l for l in lines if "fem: smallest element steps" in l)
    assert "estimates" in line and line.count("quad4 cell (nodes ") == 3, line


def test_setup_prints_spring_steps_and_the_total_mass_of_a_network(tmp_path):
    """six_dof: six unit masses, unit springs: 6 kg; a spring between two unit
    masses 2 sqrt(1/2) s, the ground spring 2 s; both partitions list three."""
    lines = setup_lines(raw_scene("six_dof"), tmp_path)
    assert figure(lines, r"total mass (\S+) kg") == 6.0
    assert not any("wave speeds" in l for l in lines)            # no material
    fem = next(l for l in lines if "fem: smallest element steps" in l)
    dem = next(l for l in lines if "dem: smallest element steps" in l)
    step = digits(2 * math.sqrt(0.5), 4)
    assert re.findall(r"(\S+) s spring (\d+-\d+)", fem) == [(str(step), "0-1"), (str(step), "1-2"),
                                                           (str(step), "2-3")]
    assert re.findall(r"(\S+) s spring (\d+-\d+)", dem) == [(str(step), "2-3"), (str(step), "3-4"),
                                                           (str(step), "4-5")]
    assert "4 elements" in fem and "3 elements" in dem           # ground-0 counts for fem


def test_setup_prints_the_lattice_bar_speed_and_the_hexahedra_steps_of_bar3d(tmp_path):
    """bar3d (solid, nu = 1/4): p wave sqrt((lambda + 2 mu)/rho) = sqrt(84 GPa /
    2700), the lattice's bar speed sqrt(E/rho); 0.4 mm cubes: L = 0.4 mm."""
    lines = setup_lines(raw_scene("bar3d"), tmp_path)
    E, rho = 70.0e9, 2700.0
    cp = math.sqrt(84.0e9 / rho)
    assert figure(lines, r"p wave (\S+) m/s") == digits(cp, 5)
    assert figure(lines, r"lattice bonds: bar sqrt\(E/rho\) (\S+) m/s") == digits(math.sqrt(E / rho), 5)
    assert figure(lines, r"fem: smallest element steps .*?: (\S+) s hex8 cell") == \
        digits(4e-4 / cp, 4)
    dem = next(l for l in lines if "dem: smallest element steps" in l)
    assert re.search(r"\S+ s bond \d+-\d+", dem), dem


def test_a_density_slip_shows_in_the_mass_and_the_wave_speeds_before_the_refusal(tmp_path):
    """rho 2.7 instead of 2700: the step is refused, but the log has already said
    why: the mass fell 1000 x, the speeds rose sqrt(1000) x, and the cells'
    estimated steps are below time.dt."""
    from solver.errors import StabilityError
    raw = raw_scene("wave_bar_fem")
    raw["model"]["material"]["rho"] = 2.7
    lines = []
    with pytest.raises(StabilityError):
        setup_lines(raw, tmp_path, lines)
    assert figure(lines, r"fem: smallest element steps .*?: (\S+) s quad4") < raw["time"]["dt"]
    assert figure(lines, r"total mass (\S+) kg") == digits(2.7 * 0.32 * 0.0024 * 3.2e-4, 6)
    assert figure(lines, r"bar sqrt\(E/rho\) (\S+) m/s") == digits(math.sqrt(70.0e9 / 2.7), 5)


def test_the_progress_line_shows_the_guards_latest_energies(tmp_path):
    """A run with a progress line every sample: kinetic, strain and work of the
    latest guard sample, and their balance, as the output's energy series has them."""
    import h5py
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 2.0
    raw["output"] = {"file": str(tmp_path / "p.h5"), "progress": 1e-9, "energy_every": 256}
    proc = run_cli([write_scene(tmp_path / "p.yaml", raw)])
    assert proc.returncode == 0, proc.stderr
    progress = [l for l in proc.stdout.splitlines() if l.startswith("[solver] t = ")]
    assert progress, proc.stdout
    m = re.search(r"energies at t = (\S+) s: kinetic (\S+) J, strain (\S+) J, work (\S+) J, "
                  r"dissipated (\S+) J, balance kinetic \+ strain \+ dissipated - work (\S+) J",
                  progress[-1])
    assert m, progress[-1]
    with h5py.File(tmp_path / "p.h5") as f:
        t = f["energy/t"][()]
        i = int(abs(t - float(m[1])).argmin())
        for name, value in (("kinetic", m[2]), ("strain", m[3]), ("external_work", m[4])):
            assert float(value) == digits(f[f"energy/{name}"][i], 4)
        balance = f["energy/kinetic"][i] + f["energy/strain"][i] - f["energy/external_work"][i]
    assert abs(float(m[6]) - balance) <= 1e-3 * abs(float(m[4]))     # undamped: ~0


# ------------------------------------------------------------------ docs
DOCS = ROOT / "docs"
BENCH = DOCS / "benchmarks"                     # the generated pages (benchmarks/tables.py)
# every page a user reads: the README and docs/**, not the developers' docs/dev/
USER_DOCS = [ROOT / "README.md",
             *sorted(p for p in DOCS.rglob("*.md") if p.relative_to(DOCS).parts[0] != "dev")]

# (page quoting, pattern over its whitespace-normalised text, page quoted): every
# figure the pattern captures must be one of the quoted page's generated figures
# (or its text, for pages without a generated block) to the quoted precision.
PAPERS = "docs/benchmarks/papers.md"      # the papers' scenes, moved out of the README
CLAIMS = [
    (PAPERS, r"audit \(kinetic \+ strain \+ released \+ dissipated = work\) closes to (\S+)\.",
     "bench_plate"),
    ("docs/heat.md", r"= work to (\S+) \((\S+) J of work, (\S+) J dissipated, (\S+) J released",
     "bench_plate"),
    ("docs/heat.md", r"It happens after (\S+) s of heating, at a bond temperature of (\d+) K",
     "bench_plate"),
    ("docs/heat.md", r"whole 100 mm width (\S+) µs of mechanical time", "bench_plate"),
    ("docs/heat.md", r"(\d+) bonds have broken by the end of the 8.93 s \((\d+) and (\d+) at 25 "
                     r"and 100", "bench_plate"),
    (PAPERS, r"ours is (\S+), at equal or better accuracy: arrival within (\S+) %, peak "
             r"within (\S+) %, reflected energy (\S+) of the incident", "bench_transition"),
    (PAPERS, r"FE step = DE step against ratio 4: (\S+) s against (\S+) s", "bench_transition"),
    (PAPERS, r"Like for like .*? time ratio is (\S+) at 5 layers", "bench_transition"),
    (PAPERS, r"explicit-implicit runs take (\d+), (\d+) and (\d+) % of it", "bench_u_tube"),
    (PAPERS, r"pay only from m ≈ 50: (\d+) % on 1 rank, (\d+) % on 2", "bench_u_tube"),
]

NUMBER = re.compile(r"\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def normalised(path: Path) -> str:
    return " ".join(path.read_text().split())


def quoted_figures(page: str) -> list[float]:
    text = (BENCH / f"{page}.md").read_text()
    found = tables.blocks(text)
    return [float(x) for x in NUMBER.findall(" ".join(t for _, t in found) if found else text)]


def matches(claim: str, values) -> bool:
    """``claim`` (as printed) is one of ``values`` rounded to its last digit."""
    mant, _, exp = claim.lower().partition("e")
    decimals = len(mant.partition(".")[2])
    ulp = 10.0 ** (-decimals + (int(exp) if exp else 0))
    return any(abs(v - float(claim)) <= 0.5 * ulp * (1 + 1e-9) for v in values)


@pytest.mark.parametrize("source, pattern, page", CLAIMS)
def test_figures_quoted_from_benchmark_pages_are_in_their_generated_tables(source, pattern, page):
    text = normalised(ROOT / source)
    m = re.search(pattern, text)
    assert m, f"{source} no longer says {pattern!r}: update the claim in this test"
    values = quoted_figures(page)
    for claim in m.groups():
        assert matches(claim.replace(",", ""), values), \
            f"{source} quotes {claim} from docs/benchmarks/{page}.md, which does not have it"


def test_matching_a_figure_respects_its_printed_precision():
    assert matches("0.038", [0.0381]) and not matches("0.038", [0.0374])
    assert matches("1.5e-5", [1.53e-05]) and not matches("1.5e-5", [1.56e-05])
    assert matches("1913", [1913.0]) and not matches("1913", [1933.0])


def test_benchmark_pages_carry_one_generated_block_of_an_existing_script():
    pages = {p.stem: p for p in BENCH.glob("bench_*.md")}
    generated = {n: tables.blocks(p.read_text()) for n, p in pages.items()}
    for name in ("bench_plate", "bench_transition", "bench_transition_stability",
                 "bench_wave_bar", "bench_metamaterial"):
        (script, text), = generated[name]
        assert script == f"{name}.py" and (ROOT / "benchmarks" / script).is_file()
        assert text.startswith("# ")


def test_tables_write_replaces_only_the_generated_block(tmp_path):
    doc = tmp_path / "bench_x.md"
    doc.write_text("intro\n<!-- generated by benchmarks/bench_x.py -->\nold\n<!-- /generated -->\nafter\n")
    assert tables.update(doc, "# new\n| 1 |")
    assert doc.read_text() == ("intro\n<!-- generated by benchmarks/bench_x.py -->\n# new\n| 1 |\n"
                               "<!-- /generated -->\nafter\n")
    other = tmp_path / "plain.md"
    other.write_text("no block\n")
    assert not tables.update(other, "x") and other.read_text() == "no block\n"


def table_rows(text: str) -> list[list[str]]:
    """Markdown tables of ``text`` as lists of their lines (header first)."""
    out, cur = [], []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            cur.append(line.strip())
        elif cur:
            out.append(cur)
            cur = []
    return out


def test_tables_copied_from_a_generated_page_match_it():
    """A table in the README or a docs page with a generated table's header
    (e.g. heat.md's copy of bench_plate's) has only rows of that table."""
    sources = {}
    for page in BENCH.glob("bench_*.md"):
        for _, text in tables.blocks(page.read_text()):
            for rows in table_rows(text):
                sources.setdefault(rows[0], set()).update(rows)
    checked = 0
    for path in USER_DOCS:
        text = path.read_text()
        for block in tables.blocks(text):
            text = text.replace(block[1], "")
        for rows in table_rows(text):
            if rows[0] in sources:
                checked += 1
                stale = [r for r in rows if r not in sources[rows[0]]]
                assert not stale, f"{path.name}: rows not in the generated table: {stale}"
    assert checked >= 1                                          # heat.md's plate table


def test_user_docs_cite_the_papers_not_seed_files():
    readme = (ROOT / "README.md").read_text()
    for path in USER_DOCS:
        text = path.read_text()
        assert not re.search(r"\bseed 00\d|shared/seeds", text, re.I), path.name
    refs = readme[readme.index("## References"):]
    for entry in ("Li Tong, Jin Xianlong, Wang Xiaowei, Pan Junming, Yang Peizhong (2023)",
                  "Ma Zhiqiang, Kong Lingshuang, Lou Yunfeng et al. (2018)",
                  "Zhang Rui, Tang Zhiping, Zheng Hang (2009)", "54(6), 419–426",
                  "49(11), 403–408", "39(2), 408–412"):
        assert entry in " ".join(refs.split()), entry


def test_no_test_counts_in_prose():
    for path in USER_DOCS:
        assert not re.search(r"\b\d+ tests\b", path.read_text()), path.name


def test_the_stable_step_key_names_the_transition_damping_it_drops():
    import dataclasses

    from solver.partitions.stability import TRANSITION_XI
    from solver.scene.sections import Guard
    doc = next(f for f in dataclasses.fields(Guard) if f.name == "stable_step").metadata["doc"]
    assert f"damping ratio below {TRANSITION_XI:g}" in doc and "dropping both" in doc, doc


# ------------------------------------------------------------------ MPI handles
@pytest.mark.parametrize("sets, code", [
    (["time.end=4e-7"], 0),                          # stress probes on a split fem partition
    (["damping.beta=0"], 2)])                        # refused after the partitions were built
def test_a_three_rank_run_leaks_no_mpi_handles(sets, code, tmp_path):
    """bar3d (the fem partition over two ranks, stress probes on it) and a
    transition scene refused for its damping after building: MPICH's yaksa
    reports no leaked handles, PETSc no unfreed objects (-objects_dump)."""
    scene = "configs/bar3d.yaml" if code == 0 else "configs/wave_bar_transition.yaml"
    args = [scene, "--set", f"output.file={tmp_path / 'x.h5'}"]
    for item in sets:
        args += ["--set", item]
    proc = run_cli(args + ["-objects_dump"], n=3, timeout=300)
    assert proc.returncode == code, proc.stderr
    assert "leaked" not in proc.stderr and "never freed" not in proc.stdout + proc.stderr, \
        proc.stderr
    if code == 0:
        assert "fem: ranks 0-1 (2)" in proc.stdout, proc.stdout


# ------------------------------------------------------------------ conserving drift
@pytest.mark.parametrize("m, fine, measured", [(4, "fem", 8.0e-13), (20, "dem", 1.8e-12)])
def test_the_conserving_invariant_holds_at_0_99_of_the_critical_step(m, fine, measured, tmp_path):
    """docs/conserving.md's row at h = 0.99 h_c: 10^5 fine steps of the 40-mass
    chain keep the invariant to the drift the table quotes (x 3: round-off
    differs between platforms)."""
    from test_conserving import chain, invariant

    from conftest import built

    def raw(dT):
        r = chain(m, dT=dT)
        if fine == "dem":
            r["partitions"][0].update(method="dem", integrator="verlet")
            del r["partitions"][0]["beta"]
        return r
    asm = built(raw(1.0), tmp_path)
    h_c = asm.freqs["fine"][1]
    asm.destroy()
    dT = 0.99 * h_c * m
    asm = built(raw(dT), tmp_path)
    assert asm.parts[0].dt == pytest.approx(0.99 * h_c, rel=1e-12)
    scheme = asm.scheme
    e0 = invariant(scheme)
    drift = 0.0
    for s in range(100_000 // m):
        scheme.step(s * dT)
        if s % 50 == 0:
            drift = max(drift, abs(invariant(scheme) - e0))
    drift = max(drift, abs(invariant(scheme) - e0))
    asm.destroy()
    assert drift / e0 < 3 * measured, drift / e0
    assert f"{measured:.1e}" in (DOCS / "conserving.md").read_text()


def test_shells_on_solids_list_their_cells_not_the_rotation_ties(tmp_path):
    """block_strip: the block partition's estimates cover its hexahedra and the
    shell triangles it owns, never the tie penalties (no cell of their own);
    the mass is the block's rho V (0.1 m cube) plus the strip's rho t A (1 x 0.1 m,
    t = 10 mm): 15.6 kg."""
    from solver import scene as scene_mod
    from solver.model import arrays, binding, element_steps
    raw = dict(raw_scene("block_strip"), output={"file": str(tmp_path / "b.h5")})
    scene = binding.bind(scene_mod.from_dict(raw))
    mdl = arrays.build(scene)
    lines = element_steps.lines(scene, mdl)
    hexes = sum(len(c) for fam, c, _ in mdl.cells if fam.name == "hex8")
    shells = [c for fam, c, _ in mdl.cells if fam.name == "shell3"][0]
    from solver.model.layout import owner_map
    owner = owner_map(mdl.n_nodes, scene.partitions)
    index = [p.name for p in scene.partitions].index("block")
    on_block = int((owner[shells] == index).any(axis=1).sum())
    line = next(l for l in lines if l.startswith("block: "))
    assert f"; {hexes + on_block} elements)" in line and "tie" not in line, line
    assert figure(lines, r"total mass (\S+) kg") == digits(7800.0 * (0.1 ** 3 + 1.0 * 0.1 * 0.01), 6)


def test_smallest_element_steps_are_those_a_stable_sort_lists():
    """element_steps.smallest: the k smallest finite steps, smallest first and
    ties by index, as a stable argsort of every step gave, on steps with many
    ties (a uniform lattice) and infinite ones (fixed ends)."""
    import numpy as np
    from solver.model.element_steps import smallest
    rng = np.random.default_rng(2)
    for _ in range(200):
        n = int(rng.integers(1, 300))
        v = rng.integers(0, 4, n).astype(float)
        v[rng.random(n) < 0.3] = np.inf
        finite = np.flatnonzero(np.isfinite(v))
        if finite.size:
            k = min(3, finite.size)
            want = finite[np.argsort(v[finite], kind="stable")[:k]]
            assert np.array_equal(smallest(v, k), want)
