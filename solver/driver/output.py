"""HDF5 output, written atomically: a temporary name, renamed when complete.

Layout::

    /                  attrs: scene, status (running|completed|failed), message, ranks,
                       wall_time, setup_wall_time, stepping_wall_time,
                       exchange_wall_time, exchange_wall_time_per_rank,
                       peak_rss_mb_per_rank, scheme,
                       external_treatment, system_dt, base_dt, n_system_steps,
                       t_end, reference, scene_yaml, steps_<partition>,
                       wall_time_<partition>
    /partitions/<name> attrs: method, integrator, ratio, dt, steps, wall_time,
                       n_owned, n_external, layers, omega_max, critical_step
    /probes/<name>/t, displacement, velocity [, stress (continua; von Mises at shell nodes),
                    reference_displacement,
                    reference_stress (bar_wave)]
    /broken_bonds   [n, 6 + dim]: t, midpoint, strain, critical strain, temperature (NaN
                    without heat), node i, node j (breakable bonds); beams
                    (model.lattice.bond: beam) [n, 8 + dim]: the same with mode (1
                    tension, 2 shear) and the energy the bond held before node i
                       attrs: node, component, partition [, max_rel_error,
                       rms_rel_error]
    /energy/t, kinetic, strain, external_work, total
    /checkpoint        (output.checkpoint, while running) the run state after
                       system step attrs[step]: see :mod:`solver.driver.state`
"""
from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np


def check_writable(path: str, restart: str | None = None, overwrite: bool = False) -> str | None:
    """Why ``path`` cannot be written (None if it can): checked before stepping,
    so a long run does not die at the end on a bad output path.  Creates no
    directory (a refused run leaves nothing behind).  Removes the temporaries
    of earlier writes of the same file whose process is gone (a run killed
    while writing).  A fresh run (no ``restart`` of this very file) does not
    replace a file that holds a checkpoint unless ``overwrite``."""
    target = Path(path)
    if target.is_dir():
        return f"output.file: {path} is a directory"
    parent = next((p for p in [target.parent, *target.parent.parents] if p.exists()), Path("."))
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        return f"output.file: cannot write {path}: {parent} is not a writable directory"
    if parent == target.parent:
        try:
            probe = target.with_name(f".{target.name}.check-{os.getpid()}")
            probe.touch()
            probe.unlink()
        except OSError as e:
            return f"output.file: cannot write {path}: {e.strerror or e}"
        remove_stale(target)
    if target.is_file() and not overwrite and not _same(target, restart):
        step = checkpoint_step(target)
        if step is not None:
            return (f"output.file: {path} holds a checkpoint at system step {step}; restart "
                    f"it with --restart {path}, replace it with --overwrite, or choose another "
                    "output.file")
    return None


def _same(a: Path, b) -> bool:
    try:
        return b is not None and a.resolve() == Path(b).resolve()
    except OSError:
        return False


def checkpoint_step(path: Path) -> int | None:
    """The system step of the checkpoint ``path`` holds, or None (none, or not ours)."""
    try:
        with h5py.File(path, "r") as f:
            return int(f["checkpoint"].attrs["step"]) if "checkpoint" in f else None
    except (OSError, KeyError, ValueError):
        return None


def remove_stale(target: Path):
    """Remove ``.NAME.tmp-PID`` / ``.NAME.check-PID`` files of ``target`` whose PID
    is not a running process (left by a run killed while writing)."""
    for tmp in target.parent.glob(f".{target.name}.*-*"):
        kind, _, pid = tmp.name[len(target.name) + 2:].rpartition("-")
        if kind not in ("tmp", "check") or not pid.isdigit():
            continue
        try:
            os.kill(int(pid), 0)
            continue                       # a live process is writing it
        except ProcessLookupError:
            pass
        except PermissionError:
            continue
        try:
            tmp.unlink()
        except OSError:
            pass


def dataset(group, name: str, data):
    """A dataset with HDF5's Fletcher32 checksum (a reader refuses flipped bytes)."""
    data = np.asarray(data)
    if data.size and data.dtype != object:
        return group.create_dataset(name, data=data, fletcher32=True)
    return group.create_dataset(name, data=data)


def broken_columns(width: int) -> str:
    """The names of /broken_bonds' ``width`` columns: 6 + dim (8, 9) for central
    bonds, 8 + dim (10, 11) for beams, which add mode and energy (0: none
    broke, the midpoint unnamed)."""
    beams = width >= 10
    dim = width - (8 if beams else 6)
    where = ", ".join("xyz"[:dim]) if width else "midpoint"
    return (f"t, {where}, strain, critical strain, temperature, "
            f"{'mode, energy, ' if beams else ''}node i, node j")


def write(path: str, result, checkpoint=None) -> None:
    """Write ``result`` (and the /checkpoint group: ``checkpoint(f)`` writes it into the
    open file, see :func:`solver.driver.state.group_writer`) to ``path`` atomically:
    readers see the old file or the new one, never a part."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(f".{target.name}.tmp-{os.getpid()}")
    try:
        with h5py.File(tmp, "w") as f:
            for k, v in result.attrs.items():
                f.attrs[k] = v
            for name, attrs in result.partitions.items():
                g = f.create_group(f"partitions/{name}")
                for k, v in attrs.items():
                    g.attrs[k] = v
            for name, probe in result.probes.items():
                g = f.create_group(f"probes/{name}")
                for k in ("t", "displacement", "velocity", "stress", "reference_displacement",
                          "reference_stress"):
                    if k in probe:
                        dataset(g, k, probe[k])
                for k, v in probe.get("attrs", {}).items():
                    g.attrs[k] = v
            g = f.create_group("energy")
            for k, v in result.energy.items():
                dataset(g, k, v)
            if result.heat is not None:
                g = f.create_group("heat")
                for k, v in result.heat.items():
                    dataset(g, k, v)
            if result.broken is not None:
                d = dataset(f, "broken_bonds", result.broken)
                d.attrs["columns"] = broken_columns(result.broken.shape[1] if
                                                    result.broken.size else 0)
            if checkpoint is not None:
                checkpoint(f)
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()
