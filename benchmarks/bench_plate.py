"""Zhang et al. (2009) §3's laser-heated plate (configs/plate_fracture.yaml): the figures
of docs/heat.md.

    python benchmarks/bench_plate.py [--quick]      (about 6 minutes; --quick: 2)
    python benchmarks/bench_plate.py --random       (about 4 minutes)

Runs the scene through the CLI
- on 1 rank with 25, 50 (the scene's) and 100 system steps per thermal step
  (the time scaling S = 1786, 893, 446): the onset of cracking (heating time,
  bond temperature, place) must not move with S;
- on 2 ranks (mpiexec -n 2: the FE and DEM partitions on their own ranks) at
  the scene's setting: the same bonds must break at the same steps.
Reports, per run: the first broken bond (heating time, temperature, x, y), the
time the crack takes to cross the plate, bonds broken, the energy audit
(kinetic + strain + released + dissipated against the external and thermal
work), the far-field FE stress before heating against the elastic F/(4 t),
and wall time against simulated time.  Writes results/bench_plate.md,
results/plate_crack.png (the crack over the particles, coloured by the time
each bond broke) and results/plate_crack_growth.png (crack length against
time).  --quick runs only the scene's setting on 1 and 2 ranks.

--random sets the lattice scene against configs/plate_fracture_random.yaml (the
same plate, the DEM strip a random packing: docs/bonds.md), the random one on
1 and 2 ranks: onset, place, temperature, crossing, audit, and the direction
of the crossing crack (the bonds broken until broken bonds first cover the
width): at each broken bond, the principal direction of the broken bonds
within 2 mm of it, folded to 0-90 degrees from x; the share within 2.5
degrees of the lattice's bond directions (0, 45, 90 degrees) says how much
the crack follows them (an isotropic crack puts 11 % there, 5.6 % at 45).
Writes results/bench_plate_random.md, docs/benchmarks/bench_plate_random.md
and results/plate_crack_random.png (about 4 minutes).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from launch import solve  # noqa: E402
from tables import write  # noqa: E402

SCENE = ROOT / "configs" / "plate_fracture.yaml"
RANDOM = ROOT / "configs" / "plate_fracture_random.yaml"
HEATING = 8.93             # seconds of heating every run covers (cracking starts at 8.86 s)
START, DT_SYS, STEP = 3.0e-4, 4 * 5.6e-8, 0.01
SIGMA_FAR = 3.5e4 / 6.5e-4  # F_b / 4 over the thickness [Pa]
SPACING = 8.0e-4
WIDTH = 0.1


def run(tmp: Path, every: int, ranks: int = 1, scene: Path = SCENE) -> Path:
    out = tmp / f"{scene.stem}_e{every}_n{ranks}.h5"
    end = int((START + HEATING * every * DT_SYS / STEP) / DT_SYS + 1e-9) * DT_SYS  # whole steps
    solve(scene, [f"heat.every={every}", f"time.end={end:.12g}", f"output.file={out}"], ranks)
    return out


def crack_length(broken, times):
    """Length of the plate's width the broken bonds cover (columns of one
    spacing holding a broken bond; midpoints that moved past an edge count in
    the edge column) at each time."""
    col = np.floor(np.clip(broken[:, 1], 0.0, WIDTH - 1e-9) / SPACING)
    return np.array([np.unique(col[broken[:, 0] <= t]).size * SPACING for t in times])


def summary(path):
    with h5py.File(path) as h:
        a = h.attrs
        b = h["broken_bonds"][()]
        b = b[np.lexsort((b[:, 7], b[:, 6], b[:, 0]))]
        scale = a["heating_time_scale"]
        e = {k: h[f"energy/{k}"][()] for k in h["energy"]}
        released = h["partitions/dem"].attrs["released_energy"]
        t, far = h["probes/far/t"][()], h["probes/far/stress"][()]
        settled = far[(t > 2.5e-4) & (t <= START)].mean()
        wall = a["stepping_wall_time"]
        t_end = a["t_end"]
    first = b[0]
    t0 = first[0]
    full = crack_length(b, b[:, 0]) >= WIDTH - 1e-9
    cross = b[np.argmax(full), 0] - t0 if full.any() else np.nan
    audit = (e["kinetic"][-1] + e["strain"][-1] + released + e["dissipated"][-1]
             - e["external_work"][-1]) / e["external_work"][-1]
    return {"b": b, "scale": scale, "onset": (t0 - START) * scale, "T": first[5],
            "x": first[1], "y": first[2], "cross": cross, "n": len(b), "audit": audit,
            "work": e["external_work"][-1], "dissipated": e["dissipated"][-1],
            "released": released, "far": settled, "wall": wall,
            "heating": (t_end - START) * scale, "mech": t_end}


def plots(s, tmp):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    b = s["b"]
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.add_patch(plt.Rectangle((0, 0), 100, 59.2, fill=False, lw=1))
    ax.axhspan(16.0, 43.2, color="0.92", zorder=0, label="DEM strip")
    sc = ax.scatter(1e3 * b[:, 1], 1e3 * b[:, 2], c=1e6 * (b[:, 0] - b[0, 0]), s=3,
                    cmap="viridis", vmax=40)
    ax.add_patch(plt.Circle((50, 29.6), 15, fill=False, ls="--", color="r", label="laser R"))
    ax.plot(1e3 * b[0, 1], 1e3 * b[0, 2], "r^", ms=8, label="first broken bond")
    ax.set_aspect("equal")
    ax.set_xlim(-2, 102)
    ax.set_ylim(-2, 61)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm] (pre-tension along y)")
    fig.colorbar(sc, label="break time after the first [us]")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"plate_fracture: {s['n']} broken bonds; first at {s['onset']:.2f} s of "
                 f"heating, {s['T']:.0f} K", fontsize=10)
    fig.tight_layout()
    fig.savefig("results/plate_crack.png", dpi=120)
    plt.close(fig)
    t = np.linspace(b[0, 0], b[0, 0] + 4e-5, 200)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(1e6 * (t - b[0, 0]), 1e3 * crack_length(b, t))
    ax.set_xlabel("time after the first broken bond [us] (mechanical clock)")
    ax.set_ylabel("crack length across the width [mm]")
    ax.axhline(100, color="0.6", ls=":")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig("results/plate_crack_growth.png", dpi=120)
    plt.close(fig)


def crossing_crack(s):
    """The broken bonds until broken bonds first cover the plate's width."""
    b = s["b"]
    return b[b[:, 0] <= b[0, 0] + s["cross"]] if np.isfinite(s["cross"]) else b


def directions(b, reach=2.0e-3):
    """At each broken bond, the principal direction (degrees from x, folded to
    0-90) of the broken bonds within ``reach`` of it (NaN with fewer than 3)."""
    from scipy.spatial import cKDTree
    x = b[:, 1:3]
    out = np.full(len(x), np.nan)
    for k, near in enumerate(cKDTree(x).query_ball_point(x, reach)):
        if len(near) >= 3:
            d = x[near] - x[near].mean(axis=0)
            w, v = np.linalg.eigh(d.T @ d)
            out[k] = np.degrees(np.arctan2(abs(v[1, -1]), abs(v[0, -1])))
    return out[np.isfinite(out)]


def random_study(tmp):
    """The lattice scene against the random packing's (1 and 2 ranks)."""
    lattice = summary(run(tmp, 50))
    rnd = summary(run(tmp, 50, 1, RANDOM))
    two = summary(run(tmp, 50, 2, RANDOM))
    lines = ["# plate_fracture on the square lattice and on a random packing", "",
             f"Heating {HEATING} s, 50 system steps per thermal step, "
             "configs/plate_fracture.yaml against configs/plate_fracture_random.yaml "
             "(the DEM strip a seeded Poisson-disc packing, Delaunay bonds within gap 1, E "
             "calibrated by a uniaxial test: docs/bonds.md).  Crossing crack: the bonds broken "
             "until broken bonds first cover the 100 mm width; its direction at each broken "
             "bond: the principal direction of the broken bonds within 2 mm, folded to 0-90 "
             "degrees from x; an isotropic crack puts 11 % within 2.5 degrees of the lattice's "
             "bond directions 0, 45 and 90 degrees, 5.6 % of 45.", "",
             "| DEM strip | ranks | onset [s of heating] | onset T [K] | at (x, y) [mm] | "
             "crossing [us] | bonds broken | crossing crack: bonds | at 0, 45, 90 deg | at 45 deg "
             "| audit | far-field error | stepping wall [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, ranks, s in (("square lattice", 1, lattice), ("random packing", 1, rnd),
                           ("random packing", 2, two)):
        c = crossing_crack(s)
        ang = directions(c)
        lines.append(
            f"| {name} | {ranks} | {s['onset']:.3f} | {s['T']:.1f} | "
            f"({1e3 * s['x']:.1f}, {1e3 * s['y']:.1f}) | {1e6 * s['cross']:.1f} | {s['n']} | "
            f"{len(c)} | {100 * np.mean(np.abs(ang - 45 * np.rint(ang / 45)) <= 2.5):.0f} % | "
            f"{100 * np.mean(np.abs(ang - 45) <= 2.5):.0f} % | {s['audit']:.1e} | "
            f"{100 * (s['far'] / SIGMA_FAR - 1):+.3f} % | {s['wall']:.0f} |")
    same = (two["b"].shape == rnd["b"].shape and
            np.array_equal(two["b"][:, [0, 6, 7]], rnd["b"][:, [0, 6, 7]]))
    lines += ["", f"Random packing, 1 vs 2 ranks: {'the same' if same else 'DIFFERENT'} broken "
              f"bonds at the same steps ({rnd['n']} vs {two['n']})."]
    write("bench_plate_random", lines, doc=True)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2), sharey=True)
    for ax, (name, s) in zip(axes, (("square lattice", lattice), ("random packing", rnd))):
        c = crossing_crack(s)
        ax.axhspan(16.0, 43.2, color="0.92", zorder=0)
        ax.add_patch(plt.Circle((50, 29.6), 15, fill=False, ls="--", color="r"))
        ax.scatter(1e3 * c[:, 1], 1e3 * c[:, 2], s=3, c=1e6 * (c[:, 0] - c[0, 0]),
                   cmap="viridis")
        ax.set_aspect("equal")
        ax.set_xlim(-2, 102)
        ax.set_ylim(10, 50)
        ax.set_xlabel("x [mm]")
        ax.set_title(f"{name}: crossing crack ({len(c)} bonds), onset {s['onset']:.2f} s, "
                     f"{s['T']:.0f} K", fontsize=9)
    axes[0].set_ylabel("y [mm]")
    fig.tight_layout()
    fig.savefig("results/plate_crack_random.png", dpi=120)
    plt.close(fig)
    print("figure: results/plate_crack_random.png")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--random", action="store_true",
                    help="the lattice scene against the random packing's")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="bench_plate_"))
    if args.random:
        return random_study(tmp)
    settings = [(50, 1), (50, 2)] if args.quick else [(25, 1), (50, 1), (100, 1), (50, 2)]
    res = {key: summary(run(tmp, *key)) for key in settings}
    lines = ["# plate_fracture (Zhang et al. 2009, §3): onset and growth of the crack", "",
             f"Heating {HEATING} s; pre-tension F_b/4 over 0.2 ms, heating from 0.3 ms.  "
             "Onset: the first broken bond (heating time, its temperature, place).  "
             "Crossing: mechanical time from the first broken bond until broken bonds "
             "cover the whole 100 mm width.  Audit: (kinetic + strain + released + "
             "dissipated - external and thermal work) / work at the end.  Far field: "
             f"FE sigma_yy at (51.6, 6.4) mm before heating against F/(4t) = "
             f"{SIGMA_FAR / 1e6:.3f} MPa.", "",
             "| system steps per thermal step | time scale S | ranks | onset [s of heating] "
             "| onset T [K] | at (x, y) [mm] | crossing [us] | bonds broken | audit | "
             "far-field error | stepping wall [s] | wall per s of heating [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (every, ranks), s in res.items():
        lines.append(
            f"| {every} | {s['scale']:.0f} | {ranks} | {s['onset']:.3f} | {s['T']:.1f} | "
            f"({1e3 * s['x']:.1f}, {1e3 * s['y']:.1f}) | {1e6 * s['cross']:.1f} | {s['n']} | "
            f"{s['audit']:.1e} | {100 * (s['far'] / SIGMA_FAR - 1):+.3f} % | {s['wall']:.0f} | "
            f"{s['wall'] / s['heating']:.1f} |")
    base = res[(50, 1)]
    onsets = [s["onset"] for (e, r), s in res.items() if r == 1]
    temps = [s["T"] for (e, r), s in res.items() if r == 1]
    lines += ["", f"Onset spread over the time scalings: {max(onsets) - min(onsets):.3f} s of "
              f"heating ({100 * (max(onsets) - min(onsets)) / base['onset']:.2f} %), "
              f"{max(temps) - min(temps):.1f} K."]
    two = res[(50, 2)]
    same = (two["b"].shape == base["b"].shape and
            np.array_equal(two["b"][:, [0, 6, 7]], base["b"][:, [0, 6, 7]]))
    lines.append(f"1 vs 2 ranks (every 50): {'the same' if same else 'DIFFERENT'} broken bonds "
                 f"at the same steps ({base['n']} vs {two['n']}); max |difference| of their "
                 f"strains {np.abs(two['b'][:, 3] - base['b'][:, 3]).max() if same else np.nan:.1e}.")
    lines.append(f"Energy (every 50, 1 rank) [J]: external and thermal work {base['work']:.4g}, "
                 f"dissipated by damping {base['dissipated']:.4g}, released by broken bonds "
                 f"{base['released']:.4g}.")
    write("bench_plate", lines, doc=not args.quick)
    plots(base, tmp)
    print("figures: results/plate_crack.png, results/plate_crack_growth.png")


if __name__ == "__main__":
    main()
