"""Error against run time: run a scene over step ratios (or base steps) and report.

    python -m solver.tools.sweep SCENE.yaml --ratios 1,2,5,10,20 [-n 1,2]
        [--treatments taylor,literal] [--schemes overlap] [--partition NAME]
        [--dts 0.001,0.002] [--out DIR] [--set k=v ...]

For every rank count, scheme, external-data treatment (for the schemes that
take coupling.external; the others show "-") and ratio eta, the coarse
partition (default: the one with the largest ratio in the scene) steps
eta*time.dt while the others keep theirs.  With --dts the base step is swept
instead (at the scene's ratios) and the observed convergence order is fitted.
Each run is a separate process (through the matching mpiexec for n > 1); its
stepping wall time, errors and the exchange wait of every rank are read back
from its HDF5 file.  Time ratio and speed-up are against the first point of
each variant (Li et al. (2023) Table 1's columns).  Writes DIR/sweep.csv,
DIR/sweep.md and DIR/sweep.png and prints the Markdown table.
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from solver.coupling.schemes import scheme_class
from solver.errors import SceneError
from solver.model.binding import load


def mpiexec() -> str:
    return os.environ.get("MTS_MPIEXEC") or shutil.which("mpiexec.mpich") or shutil.which("mpiexec")


def run_one(scene_path, n, sets, out_file, petsc_options=()):
    cmd = [sys.executable, "-m", "solver", scene_path, *sum((["--set", s] for s in sets), []),
           "--set", f"output.file={out_file}", "--set", "output.progress=0", "--overwrite",
           *petsc_options]
    if n > 1:
        cmd = [mpiexec(), "-n", str(n), *cmd]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise RunError(proc.returncode, f"run failed ({' '.join(sets)}): {tail}")
    return read_run(out_file)


class RunError(Exception):
    """A run of the sweep failed: the sweep ends with that run's exit code."""

    def __init__(self, code: int, message: str):
        super().__init__(message)
        self.code = code


def number_list(option: str, text: str | None, kind, positive=True) -> list:
    """``text`` as a comma-separated list of ``kind``, refused naming ``option``."""
    items = [x.strip() for x in (text or "").split(",")]
    if not text or not all(items):
        raise ValueError(f"{option}: expected a comma-separated list, got {text!r}")
    try:
        values = [kind(x) for x in items]
    except ValueError:
        raise ValueError(f"{option}: {text!r} is not a list of "
                         f"{'whole numbers' if kind is int else 'numbers'}") from None
    if positive and any(not (v > 0) or v != v or v == float("inf") for v in values):
        raise ValueError(f"{option}: every value must be positive and finite, got {text!r}")
    return values


def read_run(path) -> dict:
    with h5py.File(path, "r") as f:
        a = f.attrs
        n = int(a["n_system_steps"])
        row = {"stepping_s": float(a["stepping_wall_time"]), "wall_s": float(a["wall_time"]),
               "exchange_s": float(a["exchange_wall_time"]), "system_steps": n,
               "vector_rel_error": float(a.get("vector_rel_error", math.nan))}
        for name, g in f["partitions"].items():
            row[f"{name}_s"] = float(g.attrs["wall_time"])
            row[f"{name}_steps"] = int(g.attrs["steps"])
            row[f"{name}_wait_us"] = 1e6 * float(g.attrs["exchange_wall_time"]) / max(n, 1)
        probes = [dict(g.attrs) for g in f.get("probes", {}).values()]
    # the worst probe (every probe counts, on networks and continua alike)
    for key in ("max_rel_error", "rms_rel_error"):
        values = [float(p[key]) for p in probes if key in p and np.isfinite(p[key])]
        row[key] = max(values) if values else math.nan
    return row


# what each error column is, normalisation included (tables and plots)
ERRORS = {
    "max_rel_error": ("max rel. error", "worst probe: max|u − u_ref| / max|u_ref|"),
    "rms_rel_error": ("RMS rel. error", "worst probe: ‖u − u_ref‖₂ / ‖u_ref‖₂"),
    "vector_rel_error": ("eq. 9 error", "all probes as one vector: mean over t of "
                                        "‖u − u_ref‖ / ‖u_ref‖"),
}


def markdown(rows, parts, by_dt) -> str:
    x = "dt [s]" if by_dt else "η"
    head = (f"| ranks | scheme | treatment | {x} | system steps | stepping wall [s] | time ratio | "
            f"speed-up | {ERRORS['max_rel_error'][0]} | {ERRORS['rms_rel_error'][0]} |")
    extra = ["eq. 9 error"] if any(not math.isnan(r["vector_rel_error"]) for r in rows) else []
    if any(r["ranks"] > 1 for r in rows):
        extra += [f"wait {p} rank [us/step]" for p in parts]
    head = head + "".join(f" {e} |" for e in extra)
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    for r in rows:
        cells = [r["ranks"], r["scheme"], r["treatment"], r["dt"] if by_dt else r["eta"],
                 r["system_steps"], f"{r['stepping_s']:.3f}", f"{r['time_ratio']:.3f}",
                 f"{r['speedup']:.2f}", f"{r['max_rel_error']:.2e}", f"{r['rms_rel_error']:.2e}"]
        if "eq. 9 error" in extra:
            cells.append(f"{r['vector_rel_error']:.2e}")
        if any(e.startswith("wait") for e in extra):
            cells += [f"{r[f'{p}_wait_us']:.2f}" if r["ranks"] > 1 else "-" for p in parts]
        lines.append("| " + " | ".join(map(str, cells)) + " |")
    shown = ["max_rel_error", "rms_rel_error"] + (["vector_rel_error"] if "eq. 9 error" in extra
                                                  else [])
    lines += ["", *(f"- {ERRORS[k][0]}: {ERRORS[k][1]}" for k in shown)]
    return "\n".join(lines)


def error_key(rows) -> str:
    """The error the plots and orders use: eq. 9 when every row has it (several
    probes), else the worst probe's RMS relative error."""
    return "vector_rel_error" if rows and all(not math.isnan(r["vector_rel_error"])
                                              for r in rows) else "rms_rel_error"


def error_of(r, key=None) -> float:
    return r[key or ("vector_rel_error" if not math.isnan(r["vector_rel_error"])
                     else "rms_rel_error")]


def orders(rows, variants) -> list[str]:
    """Observed order of every variant, from a least-squares fit of log error on log dt."""
    out = []
    err = error_key(rows)
    for key in variants:
        sel = [r for r in rows if (r["ranks"], r["scheme"], r["treatment"]) == key]
        sel = [r for r in sel if error_of(r, err) > 0]
        if len(sel) >= 2:
            k = np.polyfit(np.log([r["dt"] for r in sel]), np.log([error_of(r, err) for r in sel]),
                           1)[0]
            out.append(f"observed order, {key[1]} / {key[2]} on {key[0]} rank(s): {k:.2f}")
    return out


def plot(rows, path, title, by_dt=False):
    """Error vs eta (or dt), error vs wall time, wall time vs eta (or dt); only
    the wall-time panel when the runs have no error (no reference).  Colour =
    scheme and treatment, line style = rank count; one legend entry per line."""
    import matplotlib  # lazy: matplotlib loads only for plots
    matplotlib.use("Agg")
    # lazy: matplotlib loads only for plots
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator
    err = error_key(rows)
    has_error = any(np.isfinite(error_of(r, err)) and error_of(r, err) > 0 for r in rows)
    n_ax = 3 if has_error else 1
    fig, axes = plt.subplots(1, n_ax, figsize=(5.2 * n_ax, 4.6), squeeze=False)
    axes = axes[0]
    ax0, ax1, ax2 = (axes[0], axes[1], axes[2]) if has_error else (None, None, axes[0])
    kinds = list(dict.fromkeys((r["scheme"], r["treatment"]) for r in rows))
    ranks = list(dict.fromkeys(r["ranks"] for r in rows))
    xkey, xlabel = ("dt", "base step dt [s]") if by_dt else ("eta", "step ratio η")
    for ki, (scheme, treat) in enumerate(kinds):
        for ri, n in enumerate(ranks):
            sel = [r for r in rows if (r["ranks"], r["scheme"], r["treatment"]) == (n, scheme, treat)]
            if not sel:
                continue
            kw = dict(color=f"C{ki}", ls=["-", "--", ":", "-."][ri % 4], marker="o", ms=4,
                      label=f"{scheme}{'/' + treat if treat != '-' else ''}, {n} rank{'s' if n > 1 else ''}")
            xs, wall = [r[xkey] for r in sel], [r["stepping_s"] for r in sel]
            ax2.semilogx(xs, wall, **kw)
            if has_error:
                ax0.loglog(xs, [error_of(r, err) for r in sel], **kw)
                ax1.loglog(wall, [error_of(r, err) for r in sel], **kw)
                if ki == 0 and ri == 0:
                    for r in sel:
                        ax1.annotate(f"{'dt' if by_dt else 'η'}={r[xkey]}",
                                     (r["stepping_s"], error_of(r, err)), fontsize=7,
                                     xytext=(4, -9), textcoords="offset points")
    name, meaning = ERRORS[err]
    ylabel = f"{name} [-]"
    if has_error:
        ax0.set(xlabel=xlabel, ylabel=ylabel, title=f"error per {'dt' if by_dt else 'η'}")
        ax1.set(xlabel="stepping wall time [s]", ylabel=ylabel, title="error against run time")
    ax2.set(xlabel=xlabel, ylabel="stepping wall time [s]",
            title=f"run time per {'dt' if by_dt else 'η'}")
    xs = sorted({r[xkey] for r in rows})
    for ax in ([ax0, ax2] if has_error else [ax2]):       # ticks at the swept values
        ax.xaxis.set_major_locator(FixedLocator(xs))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        if by_dt:
            ax.tick_params(axis="x", labelrotation=30)
    if has_error:
        readable_log(ax0.yaxis, [error_of(r, err) for r in rows])
        readable_log(ax1.yaxis, [error_of(r, err) for r in rows])
        readable_log(ax1.xaxis, [r["stepping_s"] for r in rows])
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=8)
    note = f"{name}: {meaning}" if has_error else "no reference: run time only"
    fig.suptitle(f"{title}\n{note}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def readable_log(axis, values):
    """Plain tick labels on a log axis whose data span less than a decade
    (matplotlib labels its minor ticks 6.9 x 10^-3 there)."""
    from matplotlib.ticker import FuncFormatter  # lazy: matplotlib loads only for plots
    values = [v for v in values if v > 0 and np.isfinite(v)]
    if values and max(values) < 10 * min(values):
        plain = FuncFormatter(lambda v, _: f"{v:.3g}")
        axis.set_major_formatter(plain)
        axis.set_minor_formatter(plain)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m solver.tools.sweep", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--ratios", default="1,2,3,4,5,10,20")
    ap.add_argument("--dts", help="sweep the base step instead, e.g. 0.001,0.002,0.006,0.01")
    ap.add_argument("-n", "--ranks", default="1", help="rank counts, e.g. 1,2")
    ap.add_argument("--treatments", help="external-data treatments (default: the scene's)")
    ap.add_argument("--schemes", help="coupling schemes (default: the scene's)")
    ap.add_argument("--partition", help="partition whose ratio is swept (default: largest ratio)")
    ap.add_argument("--out", help="output directory (default results/sweep_<scene>)")
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args(argv)
    try:
        scene = load(args.scene, args.sets)
        if scene.time.dt == "auto" or scene.partitions == "auto":
            raise SceneError(f"{args.scene}: sweep varies time.dt and partition ratios; this "
                             "scene has time.dt: auto or partitions: auto (./run.sh plan "
                             "compares its candidates)")
        ranks = number_list("-n", args.ranks, int)
        by_dt = args.dts is not None
        points = number_list("--dts", args.dts, float) if by_dt else \
            number_list("--ratios", args.ratios, int)
        for option, text in (("--schemes", args.schemes), ("--treatments", args.treatments)):
            if text is not None and not all(x.strip() for x in text.split(",")):
                raise ValueError(f"{option}: expected a comma-separated list, got {text!r}")
    except (SceneError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if not scene.probes:
        print(f"error: {args.scene}: probes: the scene has none; the sweep measures the error "
              "at probes (add some under probes:)", file=sys.stderr)
        return 2
    try:
        return sweep(args, scene, ranks, by_dt, points)
    except RunError as e:
        print(f"error: sweep: {e}", file=sys.stderr)
        return e.code


def whole_steps_end(scene, coarse, x, by_dt) -> list[str]:
    """``time.end=...`` on the last whole system step at or before the scene's
    end for this variant (a run ends on a whole system step), or nothing."""
    dt = x if by_dt else scene.time.dt
    ratio = max(p.ratio if (by_dt or p.name != coarse) else x for p in scene.partitions)
    system_dt = dt * ratio
    steps = int(np.floor(scene.time.end / system_dt * (1 + 1e-12)))
    end = steps * system_dt
    if steps < 1:
        raise RunError(2, f"time.end {scene.time.end:g} s is shorter than one system step "
                          f"({system_dt:g} s) at {'dt' if by_dt else 'η'} = {x}")
    if abs(end - scene.time.end) <= 1e-9 * system_dt:
        return []
    print(f"sweep: {'dt' if by_dt else 'η'} = {x}: ends at {end:.10g} s ({steps} whole system "
          f"steps of {system_dt:g} s), not {scene.time.end:g} s", flush=True)
    return [f"time.end={end!r}"]


def sweep(args, scene, ranks, by_dt, points) -> int:
    schemes = (args.schemes or scene.coupling.scheme).split(",")
    treatments = (args.treatments or scene.coupling.external).split(",")
    coarse = args.partition or max(scene.partitions, key=lambda p: p.ratio).name
    if coarse not in {p.name for p in scene.partitions}:
        print(f"error: --partition: no partition named {coarse!r}", file=sys.stderr)
        return 2
    out = Path(args.out or f"results/sweep_{scene.name}")
    (out / "runs").mkdir(parents=True, exist_ok=True)
    rows, variants = [], []
    for n in ranks:
        for scheme in schemes:
            cls = scheme_class(scheme)               # the registry, asked now
            if cls.max_ranks is not None and n > cls.max_ranks:
                print(f"sweep: skipping {scheme} on {n} ranks (it runs on at most "
                      f"{cls.max_ranks})")
                continue
            for treat in (treatments if cls.uses_external else ["-"]):
                variants.append((n, scheme, treat))
                base = None
                for x in points:
                    sets = [*args.sets, f"coupling.scheme={scheme}",
                            *([f"coupling.external={treat}"] if treat != "-" else []),
                            f"time.dt={x}" if by_dt else f"partitions.{coarse}.ratio={x}"]
                    sets += whole_steps_end(scene, coarse, x, by_dt)
                    tag = f"{scheme}_{treat}" if treat != "-" else scheme
                    f = out / "runs" / f"n{n}_{tag}_{'dt' if by_dt else 'eta'}{x}.h5"
                    row = run_one(args.scene, n, sets, f)
                    row.update(ranks=n, scheme=scheme, treatment=treat,
                               eta=scene.system_ratio if by_dt else x,
                               dt=x if by_dt else scene.time.dt)
                    base = base or row["stepping_s"]
                    row["time_ratio"] = row["stepping_s"] / base
                    row["speedup"] = base / row["stepping_s"]
                    rows.append(row)
                    print(f"sweep: n={n} {scheme}/{treat} {'dt' if by_dt else 'eta'}={x}: "
                          f"{row['stepping_s']:.3f} s, error {error_of(row):.3e} "
                          f"({ERRORS[error_key([row])][0]})", flush=True)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(out / "sweep.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    parts = [p.name for p in scene.partitions]
    table = markdown(rows, parts, by_dt)
    notes = orders(rows, variants) if by_dt else []
    what = (f"base step swept at ratio {scene.system_ratio}" if by_dt
            else f"coarse partition '{coarse}' at η x time.dt")
    (out / "sweep.md").write_text(f"{scene.name}: {what}\n\n{table}\n\n" +
                                  "".join(f"- {line}\n" for line in notes))
    plot(rows, out / "sweep.png", f"{scene.name}: error and run time", by_dt)
    print(table)
    for line in notes:
        print(line)
    print(f"sweep: wrote {out}/sweep.csv, sweep.md, sweep.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
