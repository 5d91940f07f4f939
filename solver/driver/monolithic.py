"""Monolithic reference: the same model as one partition with a fine step.

``reference: {kind: monolithic, dt, integrator}`` runs the whole model as a
single partition (fem + explicit Newmark, or dem + velocity Verlet) with step
``dt`` on one rank, and samples its probes at the coupled run's system-step
times.  The history is cached beside the output (``.reference-cache/``) under a
hash of everything it depends on, so sweeps compute it once.
"""
from __future__ import annotations

import dataclasses
import hashlib
import time
from pathlib import Path

import numpy as np

from solver.scene import Coupling, Guard, Partition, Time
from solver.driver.state import fingerprint
from solver.scene.node_set import NodeSet
from solver.driver.monitor import Probes
from solver.model.layout import owner_map
from solver.driver.build import build


def all_nodes(scene) -> NodeSet:
    """Every node a bound scene's partitions own (every node the body uses)."""
    return NodeSet(np.sort(np.concatenate([np.asarray(p.nodes, dtype=np.int64)
                                           for p in scene.partitions])))


def reference_scene(scene):
    """The single-partition scene the reference runs."""
    ref = scene.reference
    method = "dem" if ref.integrator == "verlet" else "fem"
    whole = Partition(name="reference", method=method, nodes=all_nodes(scene),
                      integrator=ref.integrator, ratio=1)
    return dataclasses.replace(scene, name=f"{scene.name}_reference",
                               time=Time(end=scene.time.end, dt=ref.dt), partitions=(whole,),
                               coupling=Coupling(), reference="none", output=None,
                               guard=Guard(stable_step=True))


def _key(scene) -> str:
    """Everything the reference history depends on: the scene's fingerprint
    (model, loads, probes, reference; networks and continua alike) and time.end."""
    h = hashlib.sha256(f"{fingerprint(scene)} {scene.time.end!r}".encode())
    return h.hexdigest()[:20]


def history(scene, t_axis, log=None) -> dict:
    """Probe displacement histories of the reference at ``t_axis``: name -> array."""
    from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when

    ref = scene.reference
    cache = Path(scene.output_file).parent / ".reference-cache" / f"{scene.name}-{_key(scene)}.npz"
    if ref.cache and cache.is_file():
        with np.load(cache) as f:
            t, data = f["t"], {p.name: f[p.name] for p in scene.probes}
    else:
        rscene = reference_scene(scene)
        n = int(round(scene.time.end / ref.dt + 1e-9))
        if log:
            log(f"[solver] reference: monolithic {ref.integrator} run, {n} steps of {ref.dt:.3g} s")
        asm = build(rscene, MPI.COMM_SELF)
        probes = Probes(rscene.probes, asm.parts, owner_map(asm.model.n_nodes,
                                                                  rscene.partitions), n)
        step = asm.scheme.step
        every = scene.output.progress if scene.output else 10.0
        t0 = last = time.perf_counter()
        for s in range(n):
            step(s * ref.dt)
            probes.record(s + 1)
            if log and every and (s & 255) == 255 and time.perf_counter() - last >= every:
                last = time.perf_counter()
                frac = (s + 1) / n
                log(f"[solver] reference: {s + 1}/{n} steps ({100 * frac:.0f}%), "
                    f"{last - t0:.1f} s elapsed, about {(last - t0) * (1 - frac) / frac:.1f} s to go")
        t = np.arange(n + 1) * ref.dt
        data = {name: h["displacement"] for name, h in probes.histories(t, n).items()}
        asm.destroy()
        if ref.cache:
            cache.parent.mkdir(parents=True, exist_ok=True)
            np.savez(cache, t=t, **data)
    stride = int(round((t_axis[1] - t_axis[0]) / ref.dt)) if t_axis.size > 1 else 1
    idx = np.arange(t_axis.size) * stride
    assert idx[-1] < t.size and np.allclose(t[idx], t_axis, rtol=0, atol=1e-9 * max(t_axis[-1], 1))
    return {name: values[idx] for name, values in data.items()}
