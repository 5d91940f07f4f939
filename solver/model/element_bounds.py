"""Every element's stable step, bounded from its own matrices, and mass scaling.

For an element e with stiffness K_e and its own lumped mass M_e (the share
of the nodes' masses it brings), lambda_e = lambda_max(M_e^-1 K_e) over its
free DOFs.  Since the nodes' masses are the sums of the elements' shares,
sum_e M_e = M, and any set S of elements satisfies

    lambda_max(M^-1 sum_{e in S} K_e) <= max_{e in S} lambda_e

(x^T K_e x <= lambda_e x^T M_e x for every e, summed).  So
``2 / sqrt(lambda_e)`` is a *bound* on the critical step of central
difference for any group of elements it belongs to, not an estimate: the
automatic levels (:mod:`solver.partitions.levels`) put each element on the
largest step ratio its bound allows, and every level is stable alone by
construction.  For the usual meshes the bound is within a few per cent to
about 30 % of the assembled operator's step (tests/test_levels.py).

Own masses: cells their family's lumped masses (:func:`solver.model.elements.lumped_mass`),
shell cells theirs with the scene's rotary inertia rule, springs of a
network a 1/degree share of each end's point mass (a node with d springs
lends each a 1/d of its mass; the shares still sum to M).  Other elements
(lattice bonds, shell-solid ties, transition bands) are not covered: a scene
that needs their bound is refused by the caller.

Mass scaling (``time.mass_scaling``, as LS-DYNA's DT2MS): an element whose
bound is below the target step gets its own mass multiplied by
(target / bound)^2, so its bound becomes the target; the added mass goes to
its nodes (translations and, on shells, rotations alike).  Since the added
masses are the elements' own, the bound above still holds for the scaled
model with the scaled own masses.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.errors import SceneError
from solver.model.elements import lumped_mass

CHUNK = 4096             # elements whose eigenvalues are computed at a time


class NotCovered(SceneError):
    """An element kind the bound does not cover."""


@dataclass
class BlockBounds:
    """The bounds of one block set (conn, Ke) of the model's stiffness blocks."""

    conn: np.ndarray          # [e, k] node ids
    steps: np.ndarray         # [e] 2 / sqrt(lambda_e) [s] (inf: no stiffness on free DOFs)
    own: np.ndarray           # [e, k, d] own lumped mass per element node and DOF
    kind: str                 # element kind, for the log
    added: np.ndarray | None = None   # [e] translational mass mass scaling added [kg]


def _dofs(mdl, conn, d):
    return mdl.dofmap.offsets[conn][:, :, None] + np.arange(d)


def _largest(K, m, free):
    """lambda_max of diag(m)^-1/2 K diag(m)^-1/2 over the free DOFs [e]."""
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(free & (m > 0), 1.0 / np.sqrt(np.where(m > 0, m, 1.0)), 0.0)
    A = s[:, :, None] * K * s[:, None, :]
    if A.shape[1] == 1:                        # a spring to the ground
        return A[:, 0, 0]
    if A.shape[1] == 2:                        # a spring between two masses
        return _two_by_two(A)
    return np.linalg.eigvalsh(A)[:, -1]


def _two_by_two(A):
    a, b, c = A[:, 0, 0], A[:, 0, 1], A[:, 1, 1]
    return 0.5 * (a + c) + np.sqrt(0.25 * (a - c) ** 2 + b * b)


def _spring_share(mdl):
    """1 / (springs at each node): the share of a node's mass each of its springs takes."""
    si, sj = np.asarray(mdl.spring_i), np.asarray(mdl.spring_j)
    ends = np.concatenate([si[si >= 0], sj[sj >= 0]])
    deg = np.bincount(ends, minlength=mdl.n_nodes).astype(float)
    return np.where(deg > 0, 1.0 / np.maximum(deg, 1.0), 0.0)


def block_bounds(scene, mdl, conn, Ke, share=None) -> BlockBounds:
    """The bounds of block set (conn, Ke); NotCovered for other element kinds."""
    conn = np.asarray(conn)
    n_el, k = conn.shape if conn.ndim == 2 else (0, 0)
    kind = type(Ke).__name__
    if kind == "CellStiffness":
        fam, X = Ke.family, Ke.points[Ke.conn]

        def own(sl, d):
            me = lumped_mass(fam, X[sl], Ke.material)                    # [e, k]
            return np.repeat(me[:, :, None], d, axis=2)
        name = fam.name
    elif kind == "ShellStiffness":
        mat = Ke.material
        rho, rotary = getattr(mat, "rho", None), getattr(mat, "rotary_inertia", None)
        if rho is None or rotary is None:
            raise NotCovered("shell cells of a shells section on solids")

        def own(sl, d):
            return Ke.lumped_mass(sl, rho, rotary)                          # [e, k, 6]
        name = Ke.family.name
    elif isinstance(Ke, np.ndarray) and k in (1, 2) and Ke.shape[1:] == (k, k) and \
            mdl.kind == "network":
        share = _spring_share(mdl) if share is None else share
        mass = np.asarray(mdl.mass, dtype=float) * share

        def own(sl, d):
            return mass[conn[sl]][:, :, None]
        name = "spring"
    else:
        what = {"Padded": "solid cells under shells", "BondStiffness": "lattice bonds",
                "RankOneBonds": "band bonds"}.get(kind, kind)
        raise NotCovered(what)
    steps = np.full(n_el, np.inf)
    owns = []
    fixed = np.asarray(mdl.fixed)
    for s in range(0, n_el, CHUNK):
        sl = slice(s, min(s + CHUNK, n_el))
        K = np.asarray(Ke[sl], dtype=float)
        m = own(sl, K.shape[1] // k)
        d = m.shape[2]
        free = ~fixed[_dofs(mdl, conn[sl], d)].reshape(len(m), -1) if fixed.size else \
            np.ones((len(m), k * d), bool)
        lam = _largest(K, m.reshape(len(m), -1), free)
        with np.errstate(divide="ignore"):
            steps[sl] = np.where(lam > 0, 2.0 / np.sqrt(np.where(lam > 0, lam, 1.0)), np.inf)
        owns.append(m)
    own_all = np.concatenate(owns) if owns else np.zeros((0, k, 1))
    return BlockBounds(conn, steps, own_all, name)


def model_bounds(scene, mdl) -> list[BlockBounds]:
    """Bounds of every element the model's fem partitions assemble (its
    stiffness blocks over all nodes).  NotCovered names what is not."""
    if mdl.lattice is not None:
        raise NotCovered("a lattice (model.lattice)")
    if mdl.zone is not None:
        raise NotCovered("a transition band (model.lattice.transition)")
    share = _spring_share(mdl) if mdl.kind == "network" else None
    return [block_bounds(scene, mdl, conn, Ke, share)
            for conn, Ke in mdl.stiffness_blocks(np.arange(mdl.n_nodes)) if len(conn)]


@dataclass(frozen=True)
class Scaling:
    """What mass scaling added: per node (translations) and per node rotation."""

    target: float
    added_mass: np.ndarray        # [n_nodes]
    added_inertia: np.ndarray     # [n_nodes] (zeros without shells)
    elements: int                 # elements whose mass was scaled
    total: int                    # elements in all
    model_mass: float             # the unscaled model's mass

    @property
    def added(self) -> float:
        return float(self.added_mass.sum())

    @property
    def fraction(self) -> float:
        return self.added / self.model_mass if self.model_mass > 0 else 0.0

    def line(self) -> str:
        return (f"mass scaling to a stable step of {self.target:.4g} s: {self.elements} of "
                f"{self.total} elements scaled, {self.added:.4g} kg added ({100 * self.fraction:.3g} % "
                f"of {self.model_mass:.4g} kg)")


def scale(bounds: list[BlockBounds], n_nodes: int, target: float, model_mass: float) -> Scaling:
    """The masses that raise every element's bound to at least ``target``; the
    bounds' steps and own masses are updated in place."""
    added_m, added_i = np.zeros(n_nodes), np.zeros(n_nodes)
    count = total = 0
    for b in bounds:
        low = b.steps < target
        total += b.steps.size
        if not low.any():
            continue
        count += int(low.sum())
        factor = (target / b.steps[low]) ** 2 - 1.0
        extra = b.own[low] * factor[:, None, None]              # [e, k, d]
        added_m += np.bincount(b.conn[low].ravel(), weights=extra[:, :, 0].ravel(),
                               minlength=n_nodes)
        if extra.shape[2] == 6:
            added_i += np.bincount(b.conn[low].ravel(), weights=extra[:, :, 3].ravel(),
                                   minlength=n_nodes)
        b.own[low] += extra
        b.steps[low] = target
        b.added = np.zeros(b.steps.size)
        b.added[low] = extra[:, :, 0].sum(axis=1)
    return Scaling(target, added_m, added_i, count, total, model_mass)
