"""``analysis: static``: K u = f once, the loads (and gravity) at their value at time.end;
``preload: static``: the same at t = 0, the dynamic run's initial displacement.

The scene is bound as one explicit fem partition over the body stepping once
to time.end (:func:`solver.model.binding._static`); its build takes no
stability check, and :class:`StaticSolve` stands in for the scheme's step:

1. the rigid-body modes the fixed DOFs leave free are found from the nodes'
   coordinates (translations and rotations about the body's centre, restricted
   to the fixed DOFs: their Gram matrix's null space) and refused, named,
   before anything is solved;
2. A = K with the fixed rows and columns made the identity, b = f(time.end)
   with 0 on them (a prescribed displacement u_p (model.prescribed) is lifted:
   b = f - K u_p, u_p on its rows);
3. a KSP with prefix ``static_`` solves A u = b: LU on one rank (on a BAIJ copy
   for vector DOFs), CG + GAMG with the rigid-body near-null space and rtol
   1e-12 on several; ``-static_ksp_type`` and the other options override;
4. the partition's u is the solution, v = a = 0, and its external work is
   1/2 f . u (the loads applied slowly from zero: it equals the strain energy;
   with prescribed displacements 1/2 u . K u, the supports' work included).

The run then records one sample at time.end (the runner drops the t = 0 one).
:func:`preloaded` solves the whole model so before a dynamic run and gives
rank 0's model the static state as u0.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from solver.errors import RunFailed, SceneError
from solver.petscutil import init, vec_on
from solver.scene import Coupling, Damping, Initial, Partition

PREFIX = "static_"
NULL = 1e-9          # a mode is free when the fixed DOFs hold it below this x the strongest


def modes(points: np.ndarray, dofs: int) -> tuple[np.ndarray, list[str]]:
    """Rigid-body modes at nodes ``points`` [n, d] (centred and scaled) on
    nodes of ``dofs`` DOFs: [n, dofs, m] and their names (translations, then
    rotations; a 6-DOF shell node's rotations take the rotation's axis)."""
    n, d = points.shape
    x = points
    names = [f"translation in {a}" for a in "xyz"[:d]]
    cols = []
    for i in range(d):
        m = np.zeros((n, dofs))
        m[:, i] = 1.0
        cols.append(m)
    if d == 2:
        m = np.zeros((n, dofs))
        m[:, 0], m[:, 1] = -x[:, 1], x[:, 0]
        cols.append(m)
        names.append("rotation about z")
    else:
        for axis in range(3):
            w = np.eye(3)[axis]
            m = np.zeros((n, dofs))
            m[:, :3] = np.cross(w, x)
            if dofs == 6:
                m[:, 3:] = w
            cols.append(m)
            names.append(f"rotation about {'xyz'[axis]}")
    return np.stack(cols, axis=-1), names


def free_modes(part, points) -> list[str]:
    """The rigid-body motions no fixed DOF of partition ``part`` holds, in
    words (collective over its ranks)."""
    lay = part.layout
    owned = lay.owned
    starts = part.starts[:owned.size]
    fixed = np.flatnonzero(part.fixed_dofs[:part.n_own])
    node = np.searchsorted(starts, fixed, side="right") - 1
    comp = fixed - starts[node]
    d = points.shape[1]
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    size = float(np.ptp(points, axis=0).max()) or 1.0
    shape, names = modes((points[owned[node]] - centre) / size, max(part.dofmap.largest, d))
    rows = shape[np.arange(fixed.size), comp] if fixed.size else np.zeros((0, len(names)))
    gram = part.comm.allreduce(rows.T @ rows)
    vals, vecs = np.linalg.eigh(gram)
    free = vecs[:, vals <= NULL * max(vals.max(), 1.0)]
    out = []
    for v in free.T:
        v = v / np.abs(v).max()
        terms = [(c, name) for c, name in zip(v, names) if abs(c) > 1e-6]
        if len(terms) == 1:
            out.append(terms[0][1])
        else:
            out.append(" + ".join(f"{c:.3g} x {name}" for c, name in terms))
    return out


class StaticSolve:
    """The static solve of the one partition of a static scene (its ``step``
    replaces the scheme's)."""

    def __init__(self, scene, asm, say, t: float | None = None, key: str = "analysis"):
        """``t``: the loads' time (default time.end); ``key``: the scene key
        a refusal names (analysis, or preload)."""
        (part,) = asm.parts
        self.part, self.t_end, self.say = part, scene.time.end if t is None else t, say
        free = free_modes(part, asm.model.points)
        if free:
            raise SceneError(
                f"{key}: static: the model is free to move ({len(free)} rigid-body "
                f"mode(s) no fixed DOF holds: {'; '.join(free)}); fix them with model.fixed, "
                "model.constraints or model.prescribed")
        P = init()
        n = part.n_own
        A = part.Kneg.duplicate(copy=True)
        A.scale(-1.0)
        lo = A.getOwnershipRange()[0]
        self.fixed = np.flatnonzero(part.fixed_dofs[:n])
        # prescribed displacements are lifted: b = f - K u_p, the solve keeps u_p on its rows
        self.K = A.duplicate(copy=True) if scene.model.kind == "continuum" and \
            scene.model.prescribed else None
        A.zeroRowsColumns((lo + self.fixed).astype(P.IntType), diag=1.0)
        ksp = P.KSP().create(part.comm)
        ksp.setOptionsPrefix(PREFIX)
        if part.comm.size == 1:
            ksp.setType("preonly")
            ksp.getPC().setType("lu")
            if A.getBlockSize() > 1 and not P.Options().hasName(f"{PREFIX}mat_type"):
                A = A.convert("baij")          # a blocked LU (solver.partitions.fem)
        else:
            ksp.setType("cg")
            ksp.getPC().setType("gamg")
            ksp.setNormType(P.KSP.NormType.UNPRECONDITIONED)    # rtol on |b - A u| / |b|
            if A.getType() == "mpibaij" and not P.Options().hasName(f"{PREFIX}mat_type"):
                A = A.convert("aij")            # (GAMG builds its graph from AIJ)
            self._near_null(A, asm.model.points, P)
        ksp.setOperators(A)
        ksp.setTolerances(rtol=1e-12)
        ksp.setFromOptions()
        self.A, self.ksp = A, ksp
        self.b = vec_on(np.zeros(n), part.comm)
        self.x = vec_on(np.zeros(n), part.comm)
        self._reasons = {v: k for k, v in vars(P.KSP.ConvergedReason).items() if isinstance(v, int)}
        size = A.getSize()[0]
        n_fixed = part.comm.allreduce(int(self.fixed.size))
        say(f"[solver]   static solve: K u = f at t = {self.t_end:.6g} s, {size} DOFs "
            f"({n_fixed} fixed), KSP "
            f"{ksp.getType()} + PC {ksp.getPC().getType()} (prefix {PREFIX})")

    def _near_null(self, A, points, P):
        """GAMG's near-null space: the rigid-body modes of the owned nodes (vector DOFs)."""
        part = self.part
        dim = points.shape[1]
        if part.dof != dim or A.getBlockSize() != dim:
            return
        xyz = np.ascontiguousarray(points[part.layout.owned], dtype=float).ravel()
        coords = P.Vec().createWithArray(xyz, comm=part.comm)
        coords.setBlockSize(dim)
        A.setNearNullSpace(P.NullSpace().createRigidBody(coords))
        coords.destroy()

    def step(self, t0: float):
        """Solve; the partition's state becomes the static one."""
        part, n = self.part, self.part.n_own
        R = np.zeros(part.held_dofs.size)
        part.loads.apply(R, self.t_end)
        f = R[:n]
        f[self.fixed] = 0.0
        b = self.b.getArray()
        b[:] = f
        if self.K is not None:
            up = self._lifted(self.t_end)
            self.K.mult(self.x, self.b)          # (x holds u_p)
            b *= -1.0
            b += f
            b[self.fixed] = up[self.fixed]
        self.ksp.solve(self.b, self.x)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise RunFailed(f"static solve did not converge ({self._reasons.get(reason, reason)}, "
                            f"{self.ksp.getIterationNumber()} iterations); check the "
                            f"-{PREFIX}ksp_* / -{PREFIX}pc_* options")
        part.U[:] = 0.0
        part.U[:n] = self.x.getArray()
        part.V[:] = 0.0
        part.A[:] = 0.0
        if self.K is None:
            part.work = 0.5 * float(np.dot(f, part.U[:n]))
        else:                                     # the loads' and the supports' work: 1/2 u.K u
            self.K.mult(self.x, self.b)
            part.work = 0.5 * float(np.dot(self.b.getArray(), part.U[:n]))    # (owned rows)
        self.say(f"[solver]   static solve: {self.ksp.getIterationNumber()} KSP iteration(s), "
                 f"{self._reasons.get(reason, reason)}")

    def _lifted(self, t: float) -> np.ndarray:
        """x = u_p: the prescribed displacements at t on their owned rows, 0 elsewhere."""
        n, motion = self.part.n_own, self.part.motion
        up = self.x.getArray()
        up[:] = 0.0
        for at, rows in (motion.groups if motion is not None else ()):
            up[rows[rows < n]] = at(t)[0]
        return up

    def destroy(self):
        for obj in (self.ksp, self.A, self.b, self.x, self.K):
            if obj is not None:
                obj.destroy()


def one_sample(result):
    """A static run's result with the state at time.end alone: the t = 0 sample
    (unloaded, before the solve) of every probe and energy series dropped."""
    def drop(series):
        n = len(series["t"])
        return {k: (v[1:] if isinstance(v, np.ndarray) and v.ndim and len(v) == n else v)
                for k, v in series.items()}
    result.probes = {name: drop(h) for name, h in result.probes.items()}
    if result.energy:
        result.energy = drop(result.energy)
    result.attrs["analysis"] = "static"
    return result


def preload_scene(scene):
    """The static scene of ``preload: static``: the whole model as one fem
    partition (every node its partitions own), the loads at t = 0."""
    from solver.driver.monolithic import all_nodes  # lazy: (monolithic builds runs of its own)
    whole = Partition(name="preload", method="fem", nodes=all_nodes(scene),
                      integrator="explicit", ratio=1)
    return dataclasses.replace(scene, name=f"{scene.name}_preload", analysis="static",
                               preload="none", partitions=(whole,), coupling=Coupling(),
                               time=dataclasses.replace(scene.time, dt=scene.time.end),
                               reference="none", output=None, initial=Initial(),
                               damping=Damping(), balance="estimated")


def preloaded(scene, comm, say, model):
    """Rank 0's model (``model``, built once: None on the other ranks) with u0
    the static state under the loads at t = 0 and gravity, solved over the
    ranks as one fem partition; the velocities of initial.motion stay."""
    from solver.driver.build import build  # lazy: build imports this module's users
    quiet = lambda *_: None                                  # noqa: E731 (the run's own log says it)
    say(f"[solver] {scene.name}: preload: the static state under the loads at t = 0 and "
        "gravity, the whole model as one fem partition")
    pscene = preload_scene(scene)
    asm = build(pscene, comm, quiet, model=model)
    try:
        solve = asm.static = StaticSolve(pscene, asm, say, t=0.0, key="preload")
        solve.step(0.0)
        part = asm.parts[0]
        mine = (part.dofmap.dofs(part.layout.owned), part.U[:part.n_own].copy())
    finally:
        asm.destroy()
    chunks = comm.gather(mine, root=0) if comm.size > 1 else [mine]
    if comm.rank != 0:
        return model
    u0 = np.zeros(model.n_dofs)
    for idx, values in chunks:
        u0[idx] = values
    say(f"[solver]   preload: the run starts from the static state at t = 0 (largest "
        f"displacement {np.abs(u0).max():.4g} m), at rest")
    return dataclasses.replace(model, u0=u0)
