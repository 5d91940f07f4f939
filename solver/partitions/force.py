"""What a partition asks for its internal force: the force interface.

A partition steps ``m a = f_ext(t) + f_int(u) - C v`` and never looks inside
``f_int``: it calls its force object's ``internal(u, out)`` (out = f_int(u)),
asks ``energy(partition)`` for the strain energy of its owned DOFs (the
energy guard), ``tangent()`` for dF/du (the stability bound and, for implicit
partitions, K_eff) and ``blocks`` for the element blocks the tangent is
assembled from.  :class:`LinearForce` is the one implementation today: the
assembled operator -K (a PETSc Mat), so ``internal`` is one MatMult.  A
breaking or contacting DEM replaces it with a force whose ``internal``
evaluates bonds and contacts at the current state and whose tangent changes.
"""
from __future__ import annotations

import numpy as np


class Force:
    """The declared interface of a partition's force object.  Every force has
    ``internal(u, out)``, ``energy(part)``, ``tangent()``, ``blocks`` and
    ``destroy()``; the defaults below describe a force with no bonds to break,
    no dashpots and no temperature, so callers ask ``force.bonded`` or
    ``force.break_strain is not None`` instead of probing attributes."""

    linear = True              # f_int = -K u with a constant K
    bonded = False             # bonds that break and release energy (BondForce)
    break_strain = None        # bonds break beyond this strain (None: nothing breaks)
    broken = ()                # this rank's broken bonds: (t, midpoint..., strain, T, i, j)
    released = 0.0             # the strain energy broken bonds released
    viscous = None             # viscous(v, out) -> dissipated power (contact dashpots), or None

    def set_temperature(self, T_node, count=True) -> float:
        """Follow model-node temperatures; returns the work it does (none here)."""
        return 0.0

    def restore_broken(self, rows):
        """Take the broken bonds of a checkpoint (nothing breaks here)."""

    def resume(self, part):
        """After a restore of ``part``'s state (collective over its pieces):
        whatever the force keeps of its last evaluation (nothing here)."""

    def contact_history(self):
        """The contacts' shear histories for a checkpoint (None: none kept)."""
        return None

    def restore_contacts(self, rows):
        """Take the contacts' shear histories of a checkpoint (none here)."""

    def orientations(self):
        """The 3D particles' orientations for a checkpoint (None: none kept)."""
        return None

    def restore_orientations(self, rows):
        """Take the particles' orientations of a checkpoint (none here)."""

    def rotation_vectors(self):
        """The owned particles' rotation vectors when their rotation DOFs are
        not (3D rotating particles; None: the DOFs are)."""
        return None

    def damage(self):
        """Per-node damage for the fields (None: nothing breaks)."""
        return None


class LinearForce(Force):
    """f_int(u) = -K u with K assembled once from element ``blocks``."""

    linear = True

    def __init__(self, Kneg, blocks):
        self.operator = Kneg              # -K over the partition's held DOFs (this rank's rows)
        self.blocks = blocks              # element block sets K was assembled from
        self.internal = Kneg.mult         # internal(u, out): out = -K u (bound: one call per step)

    def tangent(self):
        """dF/du = -K (the operator itself)."""
        return self.operator

    def energy(self, part) -> float:
        """Strain energy of the owned DOFs: 1/2 sum_owned u_i (K u)_i, which sums to
        1/2 u^T K u over all pieces because owned rows of a piece's K are complete.
        A partition that alone holds the elements on some external rows counts
        those rows too (``part.n_energy``: the conserving scheme's fine side)."""
        n = part.n_energy
        self.operator.mult(part.u, part.r)
        return -0.5 * float(np.dot(part.U[:n], part.R[:n]))

    def destroy(self):
        self.operator.destroy()
