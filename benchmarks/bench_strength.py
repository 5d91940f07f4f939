"""Strength of a random bonded packing: the Brazilian disc (configs/brazilian_disc.yaml)
and uniaxial compression (configs/compression_block.yaml), peak loads against the
analytic estimates, the cracks, and 1 vs 2 ranks.

    python benchmarks/bench_strength.py        (about 1 minute)

Runs both scenes through the CLI on 1 and 2 ranks (mpiexec -n 2: the FE jaws
and band on one rank, the particles on the other) and reports, for the disc:
- the load P(t) the jaws carry, from the rate of the prescribed motion's work:
  P = (dW/dt) / (2 v), v the speed of each jaw;
- the tensile stress at the disc's centre at the peak load, Hondros's (1959)
  solution for a load spread over the jaws' arcs 2 alpha:
  sigma = P (sin 2 alpha - alpha) / (pi R t alpha), which is 2 P / (pi D t)
  (the standard Brazilian formula) times 0.96 at alpha = 10 degrees;
- the analytic estimate of that strength for bonds that break at a strain
  eps_c: at the centre sigma_y = -3 sigma_x, so the lateral strain is
  eps_x = (1 + 3 nu) sigma_x / E, and the packing's most stretched bond
  carries c eps_x (c, the strain concentration the calibration measured and
  the log states): sigma_t = E eps_c / (c (1 + 3 nu));
- the crack: the share of broken bonds within 5 mm of the loaded diameter,
  how far along it they reach, where the first bond broke;
- the energy audit (kinetic + strain + released + dissipated against work);
for the block: the peak stress P / (W' t) (W' the block's width with the band)
against the estimate E eps_c / c', c' the calibration's most stretched bond
under uniaxial compression per unit axial strain.
Writes results/bench_strength.md, docs/benchmarks/bench_strength.md,
results/brazilian_disc.png and results/compression_block.png (load curves and
cracks).
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))
from launch import solve  # noqa: E402
from tables import write  # noqa: E402

from solver.model import calibration  # noqa: E402

DISC, BLOCK = ROOT / "configs" / "brazilian_disc.yaml", ROOT / "configs" / "compression_block.yaml"
R, T, ALPHA = 0.02, 0.02, np.radians(10.0)
E, NU, EPS_C, SEED, RAMP = 30.0e9, 0.33, 5.0e-4, 1, 5.0e-5
SPEED = {DISC: 0.02, BLOCK: 0.05}            # each jaw's or platen's speed [m/s]
WIDTH = 0.024                                # the block with its band [m]


def run(tmp: Path, scene: Path, ranks: int) -> Path:
    out = tmp / f"{scene.stem}_n{ranks}.h5"
    solve(scene, [f"output.file={out}"], ranks)
    return out


def load(path, v):
    """(t, P, broken bonds sorted by time, audit, stepping wall) of a run whose
    two driven edges move at ``v`` each."""
    with h5py.File(path) as f:
        e = {k: f[f"energy/{k}"][()] for k in f["energy"]}
        b = f["broken_bonds"][()]
        released = f["partitions/dem"].attrs["released_energy"]
        wall = f.attrs["stepping_wall_time"]
    t, W = e["t"], e["external_work"]
    speed = np.where(t < RAMP, v * t / RAMP, v)
    P = np.divide(np.gradient(W, t), 2 * speed, out=np.zeros_like(t), where=speed > 0)
    audit = (e["kinetic"][-1] + e["strain"][-1] + released + e["dissipated"][-1] - W[-1]) / W[-1]
    return t, P, b[np.lexsort((b[:, 7], b[:, 6], b[:, 0]))], audit, wall


def figure(path, size, widths, t, load, estimate, label, broken, outlines, box, title,
           colorbar=False):
    """Load against time with its estimate (left) and the broken bonds coloured
    by break time over the specimen's outlines (right), written to ``path``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a0, a1) = plt.subplots(1, 2, figsize=size,
                                 gridspec_kw=None if widths is None else {"width_ratios": widths})
    a0.plot(t, load)
    a0.axhline(estimate, color="r", ls=":", label="estimate")
    a0.set_xlabel("t [ms]")
    a0.set_ylabel(label)
    a0.legend()
    a0.grid(alpha=0.3)
    for kind, at, extent, style in outlines:
        a1.add_patch(plt.Circle(at, extent, fill=False, **style) if kind == "circle" else
                     plt.Rectangle(at, *extent, fill=False, **style))
    sc = a1.scatter(1e3 * broken[:, 1], 1e3 * broken[:, 2], s=3,
                    c=1e6 * (broken[:, 0] - broken[0, 0]), cmap="viridis")
    if colorbar:
        fig.colorbar(sc, ax=a1, label="break time after the first [us]")
    a1.set_aspect("equal")
    a1.set_xlim(*box[:2])
    a1.set_ylim(*box[2:])
    a1.set_xlabel("x [mm]")
    a1.set_title(title.format(n=len(broken)), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def same_breaks(one, two):
    return two.shape == one.shape and np.array_equal(two[:, [0, 6, 7]], one[:, [0, 6, 7]])


def main():
    tmp = Path(tempfile.mkdtemp(prefix="bench_strength_"))
    runs = {(scene, n): load(run(tmp, scene, n), SPEED[scene])
            for scene in (DISC, BLOCK) for n in (1, 2)}
    t, P, b, audit, wall = runs[(DISC, 1)]
    k = int(np.argmax(P))
    hondros = (np.sin(2 * ALPHA) - ALPHA) / (np.pi * R * T * ALPHA)
    sigma = P[k] * hondros
    m = calibration.sampled(2, 0.0, 1.0, SEED)
    c = m.concentration
    estimate = E * EPS_C / (c * (1 + 3 * NU))
    after = P[(t > t[k]) & (t < t[k] + 5e-5)].min()
    near = np.abs(b[:, 1]) < 5e-3
    same = same_breaks(b, runs[(DISC, 2)][2])
    tb, Pb, bb, audit_b, wall_b = runs[(BLOCK, 1)]
    kb = int(np.argmax(Pb))
    ucs = Pb[kb] / (WIDTH * T)
    ucs_estimate = E * EPS_C / m.lateral
    same_b = same_breaks(bb, runs[(BLOCK, 2)][2])
    lines = ["# Strength of a random packing: Brazilian disc and uniaxial compression", "",
             "configs/brazilian_disc.yaml: D = 40 mm, t = 20 mm, E 30 GPa, nu 0.33, a random "
             "packing of 0.5 mm particles, bonds breaking at a strain of 5e-4, ISRM jaws "
             "of 2 x 10 degrees moving at 0.02 m/s each.  configs/compression_block.yaml: "
             "the same material, a block 20 x 40 mm (24 mm wide with its band) between "
             "bonded FE platens moving at 0.05 m/s each.  Loads from the rate of the driven "
             "edges' work.  Disc: centre stress by Hondros's solution for the jaws' arcs, "
             "estimate E eps_c / (c (1 + 3 nu)), c the packing's strain concentration in "
             "tension.  Block: estimate E eps_c / c', c' its most stretched bond under "
             "uniaxial compression per unit axial strain (both from the calibration).", "",
             "| quantity | Brazilian disc | uniaxial compression |", "|---|---|---|",
             f"| peak load | {P[k] / 1e3:.3f} kN at {1e3 * t[k]:.3f} ms | "
             f"{Pb[kb] / 1e3:.3f} kN at {1e3 * tb[kb]:.3f} ms |",
             f"| strength | {sigma / 1e6:.3f} MPa tension at the centre (2 P / (pi D t) = "
             f"{2 * P[k] / (np.pi * 2 * R * T) / 1e6:.3f}) | {ucs / 1e6:.2f} MPa |",
             f"| estimate | {estimate / 1e6:.3f} MPa (c = {c:.3f}) | "
             f"{ucs_estimate / 1e6:.2f} MPa (c' = {m.lateral:.3f}) |",
             f"| strength / estimate | {sigma / estimate:.3f} | {ucs / ucs_estimate:.3f} |",
             f"| load 50 us after the peak | {100 * after / P[k]:.0f} % of the peak | "
             f"{100 * Pb[(tb > tb[kb]) & (tb < tb[kb] + 5e-5)].min() / Pb[kb]:.0f} % |",
             f"| first broken bond | {1e3 * b[0, 0]:.3f} ms at ({1e3 * b[0, 1]:.1f}, "
             f"{1e3 * b[0, 2]:.1f}) mm, {100 * np.interp(b[0, 0], t, P) / P[k]:.0f} % of the "
             f"peak | {1e3 * bb[0, 0]:.3f} ms at ({1e3 * bb[0, 1]:.1f}, {1e3 * bb[0, 2]:.1f}) "
             f"mm, {100 * np.interp(bb[0, 0], tb, Pb) / Pb[kb]:.0f} % of the peak |",
             f"| broken bonds | {len(b)}, {100 * near.mean():.0f} % within 5 mm of the loaded "
             f"diameter, from y = {1e3 * b[near, 2].min():.1f} to {1e3 * b[near, 2].max():.1f} "
             f"mm | {len(bb)} |",
             f"| energy audit | {audit:.1e} | {audit_b:.1e} |",
             f"| 1 vs 2 ranks | {'the same' if same else 'DIFFERENT'} broken bonds at the same "
             f"steps | {'the same' if same_b else 'DIFFERENT'} |",
             f"| stepping wall, 1 / 2 ranks | {wall:.1f} s / {runs[(DISC, 2)][4]:.1f} s | "
             f"{wall_b:.1f} s / {runs[(BLOCK, 2)][4]:.1f} s |", "",
             f"Compressive over tensile strength: {ucs / sigma:.2f} (estimates: "
             f"{ucs_estimate / estimate:.2f})."]
    write("bench_strength", lines)
    figure("results/brazilian_disc.png", (10, 4.2), None, 1e3 * t, P / 1e3,
           estimate / hondros / 1e3, "load P [kN]", b,
           [("circle", (0, 0), 20, {}), ("circle", (0, 0), 18, {"ls": ":", "color": "0.6"})],
           (-22, 22, -22, 22), f"{len(b)} broken bonds", colorbar=True)
    figure("results/compression_block.png", (8, 4.6), [1.4, 1], 1e3 * tb, Pb / (WIDTH * T) / 1e6,
           ucs_estimate / 1e6, "P / (W t) [MPa]", bb[bb[:, 0] <= tb[kb] + 5e-5],
           [("rectangle", (0, 0), (20, 40), {"ls": ":", "color": "0.6"}),
            ("rectangle", (-2, -2), (24, 44), {})],
           (-4, 24, -4, 44), "{n} bonds broken by 50 us after the peak")
    print("figures: results/brazilian_disc.png, results/compression_block.png")


if __name__ == "__main__":
    main()
