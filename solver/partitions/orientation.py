"""Orientations of rotating particles in 3D, advanced by their rotation
increments (the beam bonds of :mod:`solver.partitions.beam_bond3d` measure
their ends in them).

A 3D particle's rotation DOFs theta are stepped by its partition's
integrator like its translations, their rate being the particle's angular
velocity w in the space frame.  A sphere's inertia is isotropic (2/5 m r^2),
so Euler's equations are I dw/dt = m, the moment in the space frame, with no
gyroscopic term: the integrator steps w exactly as a translation's velocity.
theta is then the integral of w.  About a fixed axis it is the rotation
vector; about changing axes it is not (rotations do not commute), so the
orientation is kept apart, as a unit quaternion per particle, advanced at
each force evaluation by the increment of theta since the last one:

    R_new = exp([theta - theta_last]x) R_last

which is the update of the spheres of LAMMPS and YADE (exact for w constant
over the step, second order otherwise).  A tumbling bonded fragment then
follows Euler's equations of its whole body (tests/test_orientation.py: a
free dumbbell precesses at |L| / I_1 with its angular momentum kept).

The orientation depends on the path, not on theta alone: it is state, kept
in checkpoints by particle id (:meth:`Orientation.rows`), and every piece
advances its ghost copies from the same increments (the same arithmetic as
the owner's, so the ranks agree).  Quaternions are (w, x, y, z), Hamilton's
product; numpy over arrays of particles (the compiled beam loop composes them
itself: :mod:`solver.partitions.beam_bond3d_kernel`).
"""
from __future__ import annotations

import numpy as np


def quaternions(theta) -> np.ndarray:
    """[n, 4]: the unit quaternions of rotation vectors ``theta`` [n, 3]."""
    theta = np.asarray(theta, float).reshape(-1, 3)
    half = 0.5 * np.linalg.norm(theta, axis=1)
    small = half < 1e-4
    h = np.where(small, 1.0, half)
    # sin(h) / h / 2 (series below 1e-4: round-off otherwise)
    s = np.where(small, 0.5 * (1.0 - half * half / 6.0), 0.5 * np.sin(h) / h)
    return np.column_stack([np.cos(half), s[:, None] * theta])


def product(a, b) -> np.ndarray:
    """[n, 4]: the Hamilton products a b (the rotation b, then a)."""
    w1, v1 = a[:, :1], a[:, 1:]
    w2, v2 = b[:, :1], b[:, 1:]
    return np.column_stack([w1 * w2 - np.sum(v1 * v2, axis=1, keepdims=True),
                            w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def matrices(quat) -> np.ndarray:
    """[n, 3, 3]: the rotation matrices of unit quaternions ``quat`` [n, 4]."""
    w, x, y, z = np.asarray(quat, float).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], 1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], 1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1)], 1)


def vectors(quat) -> np.ndarray:
    """[n, 3]: the rotation vectors (angle at most pi) of unit quaternions ``quat``."""
    quat = np.asarray(quat, float)
    quat = np.where(quat[:, :1] < 0.0, -quat, quat)       # w >= 0: angle <= pi
    s = np.linalg.norm(quat[:, 1:], axis=1)
    angle = 2.0 * np.arctan2(s, quat[:, 0])
    scale = np.divide(angle, s, out=np.full_like(s, 2.0), where=s > 1e-300)
    return scale[:, None] * quat[:, 1:]


class Orientation:
    """The orientations of m particles whose rotation DOFs are ``theta`` [m, 3]
    now: ``quat`` [m, 4] the orientation at the last advance, ``last`` [m, 3]
    theta then (``quat`` None: the orientation is exp(theta))."""

    def __init__(self, theta, quat=None):
        self.last = np.array(theta, dtype=float).reshape(-1, 3)
        self.quat = quaternions(self.last) if quat is None else \
            np.array(quat, dtype=float).reshape(-1, 4)
        self.turned = np.empty_like(self.quat)    # the compiled loop's orientations at its q

    def __len__(self) -> int:
        return len(self.last)

    def at(self, theta) -> np.ndarray:
        """[m, 4]: the orientations at rotation DOFs ``theta`` (the last
        advance's turned by the increment since), nothing kept."""
        q = product(quaternions(np.asarray(theta)[:len(self)] - self.last), self.quat)
        return q / np.linalg.norm(q, axis=1, keepdims=True)

    def frames(self, theta) -> np.ndarray:
        """[m, 3, 3]: the rotation matrices at rotation DOFs ``theta``."""
        return matrices(self.at(theta))

    def advance(self, theta):
        """Keep the orientations at rotation DOFs ``theta`` (once per force
        evaluation along the path: the next increment starts here)."""
        self.quat = self.at(theta)
        self.last[:] = np.asarray(theta)[:len(self)]

    def keep(self, theta):
        """As :meth:`advance`, the orientations at ``theta`` being ``turned``
        (the compiled loop composed them at these rotation DOFs)."""
        self.quat, self.turned = self.turned, self.quat
        self.last[:] = np.asarray(theta)[:len(self)]

    def rows(self, ids) -> np.ndarray:
        """(id, w, x, y, z, last theta) of the first len(ids) particles,
        ``ids`` their global ids (a checkpoint's rows)."""
        n = len(ids)
        return np.column_stack([np.asarray(ids, float), self.quat[:n], self.last[:n]])

    @classmethod
    def from_rows(cls, theta, ids, rows) -> "Orientation":
        """The orientations of particles ``ids`` whose rotation DOFs are
        ``theta``: those of checkpoint ``rows`` (:meth:`rows`, any order, any
        rank's) where they hold the id, exp(theta) elsewhere (a checkpoint
        written before orientations were kept)."""
        new = cls(theta)
        rows = np.asarray(rows, dtype=float).reshape(-1, 8)
        if rows.size:
            keys = rows[:, 0].astype(np.int64)
            order = np.argsort(keys)
            keys, rows = keys[order], rows[order]
            ids = np.asarray(ids, np.int64)
            at = np.minimum(np.searchsorted(keys, ids), keys.size - 1)
            found = keys[at] == ids
            new.quat[found] = rows[at[found], 1:5]
            new.last[found] = rows[at[found], 5:]
        return new
