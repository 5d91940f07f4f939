"""Automatic multi-time-step levels: ``partitions: auto``, ``time.dt: auto``,
``time.mass_scaling`` (docs/guide/levels.md).

Every element gets the largest step ratio r (1, 2, 4, ... up to
``time.levels.max_ratio``; or its divisors with ``time.levels.ratios:
integers``) with r dt <= safety x its bound (:mod:`solver.model.element_bounds`):
the bound is rigorous, so every level is stable alone.  The elements of one
ratio form a *level*; the model becomes one fem partition whose integrator
steps each level at its own step (:mod:`solver.partitions.subcycling`), its
system step the largest ratio present.  One level only: the partition is the
plain explicit one (the uniform run, bit for bit).

``time.dt: auto``: dt is safety x the critical step of the finest level's
assembled operator (Lanczos, as the guard computes it), found by a few
fixed-point passes (a larger dt moves elements to finer levels), then
lowered so that ``time.end`` is a whole number of system steps.

:func:`resolve` runs on rank 0 with the whole model, before the partitions
are planned, and returns the resolved scene (plain keys only, plus the
element ratios the integrator looks up) and the model with scaled masses.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from solver.errors import SceneError, StabilityError
from solver.model import element_bounds, lanczos
from solver.model.arrays import dof_masses
from solver.model.cell_blocks import kept
from solver.partitions import stability
from solver.partitions.assembly import triplets
from solver.scene.sections import Partition

FIXED_POINT_PASSES = 4
BISECTIONS = 6           # when a pass overshoots: dt within 2^-6 of the largest that holds


@dataclasses.dataclass(frozen=True)
class LevelledPartition(Partition):
    """The partition ``partitions: auto`` makes: every element of the model,
    ``integrator: levels``, ``ratio`` the largest level; ``levels`` holds what
    the integrator needs (:class:`Levels`)."""

    levels: object = None


class Levels:
    """The element ratios of a levelled model and its level table.

    ``lookup(conn)`` gives the ratio of elements by their node ids (any rank,
    any share of the model: the table is keyed by the sorted node ids of
    every element)."""

    def __init__(self, h, ratios, bounds, per_block, scaling, enforce=True):
        self.h = h
        self.enforce = enforce          # guard.stable_step: an unstable level is refused
        self.ratios = tuple(int(r) for r in ratios)      # the ratios present, ascending
        self.scaling = scaling
        self._keys = {}
        for b, r in zip(bounds, per_block):
            width = b.conn.shape[1]
            keys, rs = self._keys.get(width, (np.zeros((0, width), np.int64), np.zeros(0, np.int64)))
            self._keys[width] = (np.concatenate([keys, np.sort(b.conn, axis=1)]),
                                 np.concatenate([rs, r]))
        for width, (keys, rs) in list(self._keys.items()):
            view = _rows(keys)
            order = np.lexsort(keys.T[::-1])
            view, rs = view[order], rs[order]
            # elements on the same nodes (parallel springs): the smallest ratio
            first = np.r_[True, view[1:] != view[:-1]]
            starts = np.flatnonzero(first)
            self._keys[width] = (view[starts], np.minimum.reduceat(rs, starts))

    def __repr__(self) -> str:
        """Deterministic (the checkpoint's scene fingerprint reads it): the fine
        step, the ratios and a digest of every element's ratio."""
        import hashlib  # lazy: only fingerprints ask
        digest = hashlib.sha1()
        for width in sorted(self._keys):
            keys, rs = self._keys[width]
            digest.update(keys.tobytes())
            digest.update(np.ascontiguousarray(rs, dtype=np.int64).tobytes())
        return f"Levels(h={self.h!r}, ratios={self.ratios}, elements={digest.hexdigest()[:16]})"

    def lookup(self, conn) -> np.ndarray:
        conn = np.asarray(conn)
        keys, rs = self._keys[conn.shape[1]]
        view = _rows(np.sort(conn, axis=1))
        at = np.searchsorted(keys, view)
        at = np.minimum(at, keys.size - 1)
        if not np.all(keys[at] == view):
            raise SceneError("partitions: auto: an element the levels do not know (the model "
                             "changed after levelling)")
        return rs[at]


def _rows(a):
    """Rows of an int array as one sortable value each (bytes, big-endian)."""
    a = np.ascontiguousarray(np.asarray(a, dtype=">i8"))
    return a.view(np.dtype((np.void, a.dtype.itemsize * a.shape[1]))).ravel()


def allowed(max_ratio: int, kind: str) -> np.ndarray:
    """The step ratios a level may take: powers of two up to ``max_ratio``, or
    its divisors (``integers``)."""
    if kind == "integers":
        return np.array([r for r in range(1, max_ratio + 1) if max_ratio % r == 0])
    return 2 ** np.arange(int(math.log2(max_ratio)) + 1)


def assign(bounds, h: float, ratios: np.ndarray, safety: float, buffer: int = 2
           ) -> list[np.ndarray]:
    """Per block: the largest allowed ratio r with r h <= safety x bound (1 at
    least), then ``buffer`` times: every element takes the smallest ratio at
    its nodes (a finer level grows by one element layer each time)."""
    out = []
    for b in bounds:
        at = np.searchsorted(ratios * h, safety * b.steps, side="right") - 1
        out.append(ratios[np.maximum(at, 0)])
    return buffered(bounds, out, buffer)


def level_omega(mdl, bounds, per_block, ratio, mass, cache=None) -> float:
    """omega_max of M^-1 K over the elements of one ratio (Lanczos on the
    assembled sparse operator, as the guard computes it; 0: no element).
    ``cache``: a dict kept between calls on the same model (each block's COO
    triplets are computed once)."""
    from scipy.sparse import coo_matrix, diags  # lazy: scipy loads only where it is used

    cache = {} if cache is None else cache
    rows, cols, vals = [], [], []
    for k, (b, r, (conn, Ke)) in enumerate(zip(bounds, per_block, model_blocks(mdl))):
        keep = r == ratio
        if not keep.any():
            continue
        if k not in cache:
            cache[k] = triplets([(conn, Ke)], mdl.dofmap)
        a, c, v = cache[k]
        per = a.size // len(conn)                       # entries per element, element-major
        mask = np.repeat(keep, per)
        rows.append(a[mask])
        cols.append(c[mask])
        vals.append(v[mask])
    if not rows:
        return 0.0
    rows, cols, vals = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    n = mdl.n_dofs
    A = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    s = stability.scales(mass, np.asarray(mdl.fixed), A.diagonal(), f"level {ratio}")
    A = diags(s) @ A @ diags(s)
    ger = float(abs(A).sum(axis=1).max())
    fr = stability.estimate(lambda g: (A / g).dot, lanczos.start(np.arange(n)) * (s > 0),
                            int(np.count_nonzero(s)), ger, None, f"level {ratio}")
    return fr.omega_max


def nest(per_block, ratios, buffer, bounds):
    """Every ratio present divides the largest present (integer ratios need
    not): each lowered to the largest allowed divisor of the largest, the
    buffer again, until nothing changes (lowering a ratio keeps its level
    stable).  Powers of two come back as they are."""
    while True:
        top = max(int(rs.max()) for rs in per_block)
        divisors = ratios[(top % ratios == 0) & (ratios <= top)]
        if all(np.all(top % rs == 0) for rs in per_block):
            return per_block
        lowered = [divisors[np.searchsorted(divisors, rs, side="right") - 1] for rs in per_block]
        per_block = buffered(bounds, lowered, buffer)


def buffered(bounds, per_block, layers):
    """``layers`` times: every element takes the smallest ratio at its nodes."""
    for _ in range(layers):
        n = max(int(b.conn.max()) for b in bounds) + 1
        node = np.full(n, np.iinfo(np.int64).max)
        for b, r in zip(bounds, per_block):
            np.minimum.at(node, b.conn.ravel(), np.repeat(r, b.conn.shape[1]))
        per_block = [node[b.conn].min(axis=1) for b in bounds]
    return per_block


def model_blocks(mdl):
    return [(np.asarray(c), K) for c, K in mdl.stiffness_blocks(np.arange(mdl.n_nodes)) if len(c)]


def table(bounds, per_block, h, dof_of) -> list[str]:
    """The level table's lines, the last the predicted speed-up against one
    uniform step: the cost of a level is its element matrix entries times its steps
    per system step (the stepping's MatMult work)."""
    ratios = sorted({int(r) for rs in per_block for r in np.unique(rs)})
    R = max(ratios)
    rows, total_uniform, total = [], 0.0, 0.0
    scaled = any(b.added is not None for b in bounds)
    for r in ratios:
        n_el, entries, nodes, crit, added = 0, 0.0, [], np.inf, 0.0
        for b, rs in zip(bounds, per_block):
            keep = rs == r
            if not keep.any():
                continue
            n_el += int(keep.sum())
            entries += float(keep.sum()) * (b.own.shape[1] * b.own.shape[2]) ** 2
            nodes.append(np.unique(b.conn[keep]))
            crit = min(crit, float(b.steps[keep].min()))
            added += float(b.added[keep].sum()) if b.added is not None else 0.0
        nodes = np.unique(np.concatenate(nodes))
        cost = entries * R / r
        total += cost
        total_uniform += entries * R
        rows.append((r, n_el, nodes.size, int(dof_of(nodes)), crit, cost, added))
    lines = [f"levels: {'ratio':>5} {'elements':>9} {'nodes':>8} {'DOFs':>9} "
             f"{'bound step [s]':>14} {'step [s]':>10} {'cost':>6}"
             + (f" {'added mass [kg]':>15}" if scaled else "")]
    for r, n_el, n_nodes, n_dofs, crit, cost, added in rows:
        lines.append(f"levels: {r:>5} {n_el:>9} {n_nodes:>8} {n_dofs:>9} {crit:>14.4g} "
                     f"{r * h:>10.4g} {100 * cost / total:>5.1f}%"
                     + (f" {added:>15.4g}" if scaled else ""))
    speedup = total_uniform / total if total else 1.0
    lines.append(f"levels: predicted speed-up {speedup:.3g} x against one uniform step of "
                 f"{h:.4g} s (element matrix work per system step; vector work not counted)")
    return lines


def needs(scene) -> bool:
    """Whether the scene asks for anything this module resolves."""
    return (scene.time.dt == "auto" or scene.time.mass_scaling is not None or
            any(p.integrator == "levels" for p in scene.partitions))


def resolve(scene, mdl):
    """(resolved scene, model, log lines) on rank 0 with the whole model."""
    levelled = any(p.integrator == "levels" for p in scene.partitions)
    lines = []
    t = scene.time
    bounds = None
    if levelled or t.mass_scaling is not None or t.dt == "auto":
        try:
            bounds = element_bounds.model_bounds(scene, mdl)
        except element_bounds.NotCovered as e:
            key = "partitions" if levelled else ("time.mass_scaling" if t.mass_scaling else "time.dt")
            raise SceneError(f"{key}: auto levels and mass scaling bound every element's step "
                             f"from its own matrices; this model has {e} (not covered): write "
                             "the partitions and time.dt by hand") from None
        if not bounds:
            raise SceneError(f"{'partitions' if levelled else 'time.mass_scaling'}: the model "
                             "has no element to bound")
    scaling = None
    if t.mass_scaling is not None:
        scaling, mdl = scale_mass(scene, mdl, bounds)
        lines.append(scaling.line())
    if levelled:
        mass = dof_masses(mdl, np.arange(mdl.n_nodes))
        ratios = allowed(t.levels.max_ratio, t.levels.ratios)
        if t.dt == "auto":
            h = auto_dt(scene, mdl, bounds, ratios, mass, lines)
            made = nest(assign(bounds, h, ratios, t.safety, t.levels.buffer), ratios,
                        t.levels.buffer, bounds)
            top = max(int(rs.max()) for rs in made)
            n = max(1, math.ceil(t.end / (top * h) * (1 - 1e-12)))
            h = t.end / (n * top)
            ratios = ratios[ratios <= top]
            scene = dataclasses.replace(scene, time=dataclasses.replace(t, dt=h))
        else:
            h = t.dt
            steps = round(t.end / h)               # a whole number (Scene.validate)
            ratios = ratios[steps % ratios == 0]   # the system step must divide time.end
        per_block = nest(assign(bounds, h, ratios, t.safety, t.levels.buffer), ratios,
                         t.levels.buffer, bounds)
        present = sorted({int(r) for rs in per_block for r in np.unique(rs)})
        lines += table(bounds, per_block, h, mdl.dofmap.count)
        lev = Levels(h, present, bounds, per_block, scaling, scene.guard.stable_step)
        R = present[-1]
        spec = dataclasses.replace(scene.partitions[0], integrator="levels" if len(present) > 1
                                   else "explicit", ratio=R, beta=0.0, gamma=0.5)
        spec = LevelledPartition(**{f.name: getattr(spec, f.name)
                                    for f in dataclasses.fields(Partition)}, levels=lev)
        scene = dataclasses.replace(scene, partitions=(spec,))
        if len(present) == 1:
            lines.append(f"levels: one level: the uniform explicit run at {R} x {h:.4g} s")
    scene.scheme.validate(scene)          # the scheme's rules on the levelled partition
    return scene, mdl, lines


def scale_mass(scene, mdl, bounds):
    spec = scene.time.mass_scaling
    if mdl.kind != "continuum":
        raise SceneError("time.mass_scaling: mass scaling adds element masses: continuum "
                         "models only")
    smallest = min(float(b.steps.min()) for b in bounds)
    if spec.dt <= smallest:
        raise SceneError(f"time.mass_scaling.dt: {spec.dt:.4g} s is at or below every element's "
                         f"stable step (the smallest bound is {smallest:.4g} s): it adds no mass")
    scaling = element_bounds.scale(bounds, mdl.n_nodes, spec.dt, float(np.sum(mdl.mass)))
    if scaling.fraction > spec.max_added:
        raise SceneError(f"time.mass_scaling.dt: {spec.dt:.4g} s adds {scaling.added:.4g} kg, "
                         f"{100 * scaling.fraction:.3g} % of the model's {scaling.model_mass:.4g} "
                         f"kg, above time.mass_scaling.max_added ({100 * spec.max_added:.3g} %)")
    shells = mdl.shells
    if shells is not None:
        shells = dataclasses.replace(shells, inertia=shells.inertia + scaling.added_inertia)
    return scaling, dataclasses.replace(mdl, mass=mdl.mass + scaling.added_mass, shells=shells)


def auto_dt(scene, mdl, bounds, ratios, mass, lines) -> float:
    """The largest dt found with dt <= safety x the critical step of the
    finest level it makes (a larger dt moves elements to the finest level, so
    a few passes): from safety x the smallest bound, which always holds."""
    safety = scene.time.safety
    cap = min(safety, 1 - 1e-6)                  # never the critical step itself
    h = safety * min(float(b.steps.min()) for b in bounds)
    cache = {}

    def finest(step):
        per = assign(bounds, step, ratios, safety, scene.time.levels.buffer)
        omega = level_omega(mdl, bounds, per, 1, mass, cache)
        return 2.0 / omega if omega > 0 else np.inf
    crit = finest(h)
    for _ in range(FIXED_POINT_PASSES):
        candidate = cap * crit
        if not np.isfinite(candidate) or candidate <= h * (1 + 1e-9):
            break
        c = finest(candidate)
        if candidate > cap * c:                   # too far: bisect between h and it
            lo, hi = h, candidate
            for _ in range(BISECTIONS):
                mid = 0.5 * (lo + hi)
                c_mid = finest(mid)
                if mid <= cap * c_mid:
                    lo, crit = mid, c_mid
                else:
                    hi = mid
            h = lo
            break
        h, crit = candidate, c
    lines.append(f"time.dt auto: {h:.6g} s, the finest level's critical step {crit:.6g} s "
                 f"(Lanczos) x {h / crit:.4g} (time.safety {safety:g})")
    return h


def level_blocks(blocks, levels, ratio):
    """The block sets of the elements of one ratio."""
    out = []
    for conn, Ke in blocks:
        if not len(conn):
            continue
        keep = levels.lookup(conn) == ratio
        if keep.any():
            out.append(kept(np.asarray(conn), Ke, keep))
    return out


def operators(p, blocks, levels) -> dict:
    """{ratio: r dt M^-1 (-K_r)} of a levelled partition ``p`` over its held
    DOFs (rows no element of the level touches stay empty): MatMult gives the
    level's whole velocity kick.  Each level is checked before stepping on
    its operator: omega_max r dt < 2 with the full nodal masses (Lanczos;
    collective)."""
    R = p.spec.ratio
    h = p.dt / R
    ops = {}
    for r in (r for r in levels.ratios if r <= R):
        K = p.operator(level_blocks(blocks, levels, r), scale=-1.0)
        K.setName(f"{p.name}_level{r}")
        ops[r] = K
        fr = stability.from_operator(K, p.mass, p.fixed_dofs, p.held_dofs, f"{p.name} level {r}")
        if fr.omega_max * r * h >= 2.0:
            step, crit = stability.seconds(r * h, fr.critical_step(2.0))
            problem = (f"partitions: auto: level {r} steps {step} s, beyond its critical step "
                       f"{crit} s (omega_max {fr.omega_max:.4g} rad/s, {fr.method}); lower "
                       "time.dt or time.safety")
            if levels.enforce:
                for op in ops.values():
                    op.destroy()
                raise StabilityError(problem)
            p.built.append(f"warning: {problem}; guard.stable_step is false: running anyway")
        kick = K.createVecLeft()
        kick.getArray()[:] = r * h * p.inverse_mass         # 0 on fixed DOFs
        K.diagonalScale(L=kick)
        kick.destroy()
        n = int(K.getInfo()["nz_used"])
        p.built.append(f"level {r}: operator ({n} nonzeros), step {r * h:.4g} s, critical "
                       f"{fr.critical_step(2.0):.4g} s ({fr.method})")
    return ops
