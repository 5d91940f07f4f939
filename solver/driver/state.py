"""The state of a run between two system steps: exactly what a checkpoint holds.

Between system steps a run is determined by

* the owned (u, v, a) of every partition, keyed by global node id (so a run
  can restart on another rank count: external copies are refreshed from their
  owners by one exchange, which is what the last system step ended with);
* per partition: steps done, external work, damping dissipation, the energy
  broken bonds released and the last load values of every load function (the
  work increment's f_n); the broken bonds (time, midpoint, strain, particles)
  of breakable lattices; the contacts' shear histories (friction_model:
  history: particle ids, xi, last separation); the orientations of 3D
  rotating particles (id, quaternion, rotation DOFs at it:
  :class:`solver.partitions.orientation.Orientation`);
* the energy guard: its samples so far, initial energy, largest |work|;
* the probe histories so far and the number of system steps done.

Newmark's predictors (u~, v~) are recomputed at every step and are not state.
:func:`collect` gathers this to rank 0; :func:`restore` puts it back into a
freshly built run.  A checkpoint is the output file itself (``/checkpoint``
beside the histories), written atomically, so the file is valid at every
instant; a completed file keeps its final state (a restart with a later
time.end continues it) and a failed one its last good checkpoint.  :func:`fingerprint` identifies the scene a checkpoint belongs to:
everything but ``time.end`` (a restart may run longer) and ``output``.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np
import h5py

from solver.driver.output import dataset
from solver.collective import on_root
from solver.errors import SceneError
from solver.scene.node_set import NodeSet

FORMAT = "mts-checkpoint 1"


def _plain(obj):
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, NodeSet):             # as the tuple of ids it was: checkpoints hash so
        return obj.ids.tolist()
    if isinstance(obj, np.ndarray):
        return "sha256:" + hashlib.sha256(np.ascontiguousarray(obj).tobytes()).hexdigest()
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, float):
        return repr(obj)
    return obj if isinstance(obj, (int, str, bool, type(None))) else repr(obj)


# keys added since 2026-12-03, by path ("*": every item of a list), with their
# unset value: they count only when set
NEWER_KEYS = ((("analysis",), "dynamic"), (("gravity",), None), (("preload",), "none"),
              (("initial", "motion"), []), (("model", "integration"), "full"),
              (("model", "material", "membrane"), "allman"), (("model", "sections"), []),
              (("loads", "*", "pressure"), False), (("model", "hourglass"), 0.1),
              (("model", "prescribed"), []), (("model", "lattice", "weibull_modulus"), None),
              (("model", "lattice", "seed"), 0),
              (("model", "lattice", "contact", "friction_model"), "viscous"),
              (("model", "lattice", "contact", "tangential_stiffness"), 2.0 / 7.0),
              (("model", "lattice", "gap"), None), (("model", "lattice", "radius_spread"), None),
              (("model", "lattice", "strength"), "bond"),
              (("model", "lattice", "bond"), "central"),
              (("model", "lattice", "shear_ratio"), None),
              (("model", "lattice", "friction_angle"), None),
              (("model", "lattice", "contact", "rolling_friction"), None))


def _drop_unset(section, path, unset):
    """Remove the key at ``path`` below ``section`` where it holds ``unset``."""
    if not path or not isinstance(section, (dict, list)):
        return
    if path[0] == "*":
        for item in section if isinstance(section, list) else ():
            _drop_unset(item, path[1:], unset)
    elif isinstance(section, dict):
        if len(path) == 1:
            if section.get(path[0], unset) in (unset, _plain(unset)):
                section.pop(path[0], None)
        else:
            _drop_unset(section.get(path[0]), path[1:], unset)


def fingerprint(scene, ranks: bool = False) -> str:
    """Hash of everything that determines the trajectory (not time.end, not output,
    not how the ranks were balanced or how many a partition asked for:
    ``partitions[].ranks`` counts as unset, so a run restarts on another rank
    count with other ranks given; a checkpoint written without them hashes
    as before).  ``ranks``: the hash that versions before 2026-12-03 wrote,
    with the ranks given (their checkpoints are read too)."""
    data = _plain(scene)
    for name in ("output", "balance", "balance_steps"):
        data.pop(name, None)
    for path, unset in NEWER_KEYS:            # a scene without them hashes as before
        _drop_unset(data, path, unset)
    for part in data.get("partitions") or ():
        if isinstance(part, dict) and "ranks" in part and not ranks:
            part["ranks"] = None
    data["time"].pop("end", None)
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:32]


def collect(k: int, parts, guard, comm, scheme=None) -> dict | None:
    """This run's state after ``k`` system steps, merged on rank 0 (None elsewhere);
    ``guard`` None: without the energy guard's (a run not yet watched)."""
    memory = scheme.memory() if scheme is not None else {}
    memories = comm.gather(memory, root=0) if comm.size > 1 else [memory]
    local = []
    for p in parts:
        n = p.n_own
        released = p.force.released if p.force.bonded else 0.0
        local.append((p.name, p.layout.owned, p.state[:, :n].copy(),
                      np.array([p.work, p.dissipated, released]), p.steps,
                      p.load_memory(), list(p.force.broken), p.force.contact_history(),
                      p.force.orientations()))
    chunks = comm.gather(local, root=0) if comm.size > 1 else [local]
    if comm.rank != 0:
        return None
    merged: dict = {}
    for chunk in chunks:
        for name, nodes, uva, work, steps, loads, broken, contacts, turned in chunk:
            m = merged.setdefault(name, {"nodes": [], "uva": [], "work": np.zeros(3), "steps": steps,
                                         "loads": {}, "broken": [], "contacts": [],
                                         "orientations": []})
            m["nodes"].append(nodes)
            m["uva"].append(uva.reshape(3, nodes.size, -1))
            m["work"] += work
            m["loads"].update(loads)
            m["broken"] += broken
            if contacts is not None:
                m["contacts"].append(contacts)
            if turned is not None:
                m["orientations"].append(turned)
    parts_out = {}
    for name, m in merged.items():
        nodes = np.concatenate(m["nodes"])
        order = np.argsort(nodes, kind="stable")
        uva = np.concatenate(m["uva"], axis=1)[:, order]
        keys = np.array(sorted(m["loads"]), dtype=np.int64)
        parts_out[name] = {"nodes": nodes[order], "uva": uva, "work": m["work"],
                           "steps": m["steps"], "load_keys": keys,
                           "load_values": np.array([m["loads"][int(i)] for i in keys]),
                           "broken": np.array(sorted(m["broken"]), dtype=float)}
        if m["contacts"]:                     # the contacts' shear histories, by pair
            rows = np.concatenate(m["contacts"])
            parts_out[name]["contacts"] = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
        if m["orientations"]:                 # 3D rotating particles' orientations, by id
            rows = np.concatenate(m["orientations"])
            parts_out[name]["orientations"] = rows[np.argsort(rows[:, 0], kind="stable")]
    merged_memory = {}
    for m in memories:
        for key, value in m.items():
            merged_memory.setdefault(key, value)
    return {"step": k, "parts": parts_out, "guard": guard.memory() if guard is not None else None,
            "scheme": merged_memory}


def restore(data: dict, parts, scheme, guard):
    """Put checkpoint ``data`` (on every rank) into a freshly built run, or into
    one that stepped since ``data`` was collected (:mod:`solver.driver.balance`);
    ``guard`` None: the state without the energy guard's."""
    for p in parts:
        saved = data["parts"][p.name]
        nodes, uva = saved["nodes"], saved["uva"]
        pos = np.searchsorted(nodes, p.layout.owned)
        n = p.n_own
        p.state[:, :n] = uva[:, pos].reshape(3, n)
        p.steps = int(saved["steps"])
        # the work of a partition on several ranks is summed over its pieces:
        # keep it on the first one
        # external work, dissipated, released (older checkpoints: the first two)
        work = np.atleast_1d(np.asarray(saved["work"], dtype=float))
        first = p.layout.piece == 0
        p.work = float(work[0]) if first else 0.0
        p.dissipated = float(work[1]) if first and work.size > 1 else 0.0
        p.restore_load_memory(dict(zip(saved["load_keys"].tolist(),
                                       saved["load_values"].tolist())))
        p.force.restore_broken(saved["broken"])
        if work.size > 2 and p.force.bonded:      # (older checkpoints: from the rows)
            p.force.released = float(work[2]) if first else 0.0
        p.force.restore_contacts(saved.get("contacts", ()))
        p.force.restore_orientations(saved.get("orientations", ()))
    scheme.synchronise()
    for p in parts:
        p.force.resume(p)
    scheme.restore_memory(data.get("scheme") or {})
    if guard is not None:
        guard.restore(data["guard"])


def group_writer(checkpoint):
    """For :func:`solver.driver.output.write`: a function of the open file that writes
    ``checkpoint`` = (data, meta) as /checkpoint, or None without one."""
    if checkpoint is None:
        return None
    return lambda f: write_group(f, *checkpoint)


def write_group(f, data: dict, meta: dict):
    """Write ``data`` (from :func:`collect`) as group /checkpoint of open h5py file ``f``."""
    g = f.create_group("checkpoint")
    g.attrs["format"] = FORMAT
    g.attrs["step"] = data["step"]
    for k, v in meta.items():
        g.attrs[k] = v
    for name, part in data["parts"].items():
        pg = g.create_group(f"partitions/{name}")
        for k in ("nodes", "uva", "load_keys", "load_values", "broken", "contacts",
                  "orientations"):
            if k in part:
                dataset(pg, k, part[k])
        pg.attrs["work"] = part["work"]
        pg.attrs["steps"] = part["steps"]
    gg = g.create_group("guard")
    for k, v in data["guard"]["series"].items():
        dataset(gg, k, np.asarray(v, dtype=float))
    gg.attrs["initial"] = data["guard"]["initial"]
    gg.attrs["max_work"] = data["guard"]["max_work"]
    sg = g.create_group("scheme")
    for k, v in data.get("scheme", {}).items():
        dataset(sg, k, v)
    g.attrs["digest"] = attrs_digest(g)


def attrs_digest(group) -> str:
    """sha256 of the checkpoint's scalar attributes (the datasets carry Fletcher32
    checksums of their own): a flipped step count or work is refused too."""
    items = []

    def visit(name, obj):
        for key in sorted(obj.attrs):
            if key != "digest":
                items.append((name, key, np.asarray(obj.attrs[key]).tobytes()))
    visit("", group)
    group.visititems(lambda name, obj: visit(name, obj) if isinstance(obj, h5py.Group) else None)
    h = hashlib.sha256()
    for name, key, raw in sorted(items):
        h.update(f"{name}/{key}=".encode() + raw)
    return h.hexdigest()


def read(path: str, scene, comm) -> dict:
    """Checkpoint data of ``path`` for ``scene`` (read on rank 0, broadcast).

    Refuses (SceneError naming the file) a missing, non-HDF5, truncated or
    foreign file, one without a checkpoint, or one written for another scene."""
    return on_root(comm, _read, path, scene)


def _read(path: str, scene) -> dict:
    where = f"--restart {path}"
    if not Path(path).is_file():
        raise SceneError(f"{where}: file not found")
    try:
        with h5py.File(path, "r") as f:
            if "checkpoint" not in f:
                raise SceneError(f"{where}: has no checkpoint (run with output.checkpoint.every)")
            g = f["checkpoint"]
            if g.attrs.get("format") != FORMAT:
                raise SceneError(f"{where}: checkpoint format {g.attrs.get('format')!r}, this "
                                 f"version reads {FORMAT!r}")
            if g.attrs.get("digest") != attrs_digest(g):
                raise SceneError(f"{where}: the checkpoint is damaged (its attributes do not "
                                 "match their checksum); the file is left as it is")
            if g.attrs.get("fingerprint") not in (fingerprint(scene), fingerprint(scene, True)):
                raise SceneError(f"{where}: written for scene {g.attrs.get('scene')!r} with other "
                                 "model, partitions, steps or loads than this scene (only "
                                 "time.end and output may change on restart)")
            k = int(g.attrs["step"])
            if k > scene.n_system_steps:
                raise SceneError(f"{where}: checkpoint at system step {k} is beyond time.end "
                                 f"({scene.n_system_steps} system steps)")

            def get(group, name):
                try:
                    return group[name][()]
                except OSError as e:             # Fletcher32 mismatch, unreadable chunk
                    raise SceneError(f"{where}: dataset {group[name].name} is damaged "
                                     f"({' '.join(str(e).split())[:120]}); the file is left as "
                                     "it is") from None
            parts = {}
            for name, pg in g["partitions"].items():
                parts[name] = {k2: get(pg, k2) if k2 in pg else np.zeros(0)
                               for k2 in ("nodes", "uva", "load_keys", "load_values", "broken",
                                          "contacts", "orientations")}
                parts[name].update(work=np.atleast_1d(pg.attrs["work"]).astype(float),
                                   steps=int(pg.attrs["steps"]))
                if not np.all(np.isfinite(parts[name]["uva"])):
                    raise SceneError(f"{where}: partition {name!r}'s state in the checkpoint is "
                                     "not finite")
            memory = {k2: get(g["scheme"], k2) for k2 in g.get("scheme", {})}
            gg = g["guard"]
            guard = {"series": {k2: get(gg, k2).tolist() for k2 in gg},
                     "initial": float(gg.attrs["initial"]),
                     "max_work": float(gg.attrs["max_work"])}
            # the histories of the file run to where it stopped (an interrupted or
            # failed run goes on after its last checkpoint): keep them to step k
            probes = {}
            for name in f.get("probes", {}):
                pg = f[f"probes/{name}"]
                series = [get(pg, "displacement"), get(pg, "velocity"),
                          *((get(pg, "stress"),) if "stress" in pg else ())]
                if any(x.size < k + 1 for x in series):
                    raise SceneError(f"{where}: probe {name!r} has {series[0].size} samples, the "
                                     f"checkpoint is at system step {k}")
                probes[name] = tuple(x[:k + 1] for x in series)
            heat = None
            if "heat" in f and "t" in f["heat"]:
                hg = f["heat"]
                keep = np.rint(get(hg, "t") / scene.system_dt) < k   # samples before step k
                heat = {k2: get(hg, k2)[keep] for k2 in hg}
    except SceneError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as e:
        raise SceneError(f"{where}: not a readable checkpoint ({str(e).splitlines()[0]})") from None
    want = {p.name for p in scene.partitions}
    if set(parts) != want:
        raise SceneError(f"{where}: holds partitions {sorted(parts)}, the scene has {sorted(want)}")
    return {"step": k, "parts": parts, "guard": guard, "probes": probes, "heat": heat,
            "scheme": memory}
