"""f_int(u) of a dem partition whose particles rotate, joined by beam bonds
(``model.lattice.bond: beam``).

Every particle carries (u_x, u_y, theta) in 2D, (u, theta) in 3D, theta's
rate its angular velocity and its orientation kept apart (an
:class:`~solver.partitions.orientation.Orientation`, advanced after every
evaluation, in checkpoints; the model's nodes have three or six DOFs:
:mod:`solver.model.continuum`), and its bonds are the co-rotational beams of
:mod:`solver.partitions.beam_bond` (2D) or
:mod:`solver.partitions.beam_bond3d` (3D), evaluated by their compiled loops
(:mod:`solver.partitions.beam_bond_kernel`,
:mod:`solver.partitions.beam_bond3d_kernel`) from the current positions and
rotations: a rigid motion of a bonded cluster, however large its rotation,
exerts no force or torque.  The ghost particles (another piece's, on a
partition split over ranks), the bond order and the energy shares are those
of :class:`~solver.partitions.bonds.BondForce`, which this extends; the
other elements (bonds carried to a transition band's nodes) stay linear,
one MatMult.  With ``model.lattice.break_strain`` a beam breaks in tension
(its most stretched fibre) or in shear (Mohr-Coulomb), its mode recorded
(:meth:`BeamBonds.breakable`).  With ``model.lattice.contact`` particles
that share no live beam touch as in :mod:`solver.partitions.contact`, whose
shear springs and friction then also turn them (the contact point rolls
with their rotations; the tangential force's moment acts on both).  With
``heat`` a beam at temperature T (its ends' mean) rests at the length
L0 (1 + alpha (T - T0)) (its rest angle and bending unchanged), and with
``heat.melting`` its tensile and shear strengths fall with T as the
central bonds' (:mod:`solver.partitions.bonds`).
"""
from __future__ import annotations

import numpy as np

from solver.model.calibration import torsion
from solver.partitions.beam_bond import BeamBonds
from solver.partitions.beam_bond3d import BeamBonds3D
from solver.partitions.bonds import BondForce
from solver.partitions.orientation import Orientation, matrices, vectors


class BeamBondForce(BondForce):
    """Co-rotational beam bonds between rotating particles, breaking in
    tension or shear when given a ``break_strain`` (``shear``: (shear_ratio,
    tan friction angle); ``weibull``: the strengths' spread); ``contact``:
    the particles' contact settings (``node_mass``: the model's masses)."""

    def __init__(self, part, lattice_block, linear_op, other_blocks, tangent, break_strain=None,
                 weibull=None, shear=None, contact=None, node_mass=None, heat=None):
        super().__init__(part, lattice_block, linear_op, other_blocks, tangent, break_strain,
                         contact, heat, node_mass, weibull)
        conn, stiff = lattice_block
        at = {(int(a), int(b)): n for n, (a, b) in enumerate(conn.tolist())}
        k_b = stiff.k_b[[at[(int(a), int(b))] for a, b in self.nodes.tolist()]]
        if self.space == 2:
            # lazy: numba loads only when a partition with beam bonds is built
            from solver.partitions.beam_bond_kernel import beam_forces
            self.beams = BeamBonds(self.i, self.j, self.dX, self.k, k_b)
        else:
            # lazy: as above
            from solver.partitions.beam_bond3d_kernel import beam_forces3d
            self.beams = BeamBonds3D(self.i, self.j, self.dX, self.k, k_b, torsion(k_b))
            self._R = np.empty((self._n_bonded, 3, 3))   # (held and bond ghosts: no halo)

            def beam_forces(bonds, q, *args):
                return beam_forces3d(bonds, q, *args, orientation=self._orientation(q), R=self._R)
        self._beam_forces = beam_forces
        self.orientation = None         # 3D: the particles' Orientation (at the first evaluation)
        self._pending = ()              # 3D: a checkpoint's orientations (resume takes them)
        self.beams.alive = self.alive                    # one mask: breaks, damage, energy
        self._shear_ratio = 1.0
        if break_strain is not None:
            ratio, friction = shear
            self._shear_ratio = ratio
            self.beams.breakable(self.limit, ratio * self.limit, friction)
        self._mode = np.zeros(len(self.k), np.int64)

    def separations(self, u, bonds=slice(None)):
        s = self.space
        return self.dX[bonds] + (u[self.j[bonds], :s] - u[self.i[bonds], :s])

    def _split(self, q):
        """(displacements, rotations) of q: theta [m] in 2D, the particles'
        rotation matrices [m, 3, 3] in 3D (their orientations at q's rotation
        DOFs)."""
        s = self.space
        if s == 2:
            return q[:, :s], q[:, s]
        return q[:, :s], self._orientation(q).frames(q[:self._n_bonded, s:])

    def _orientation(self, q):
        """The particles' :class:`~solver.partitions.orientation.Orientation`
        (3D; the first call's q gives exp(theta))."""
        if self.orientation is None:
            self.orientation = Orientation(q[:self._n_bonded, 3:])
        return self.orientation

    def _advance(self, q, kept=False):
        """3D: the orientations move on to q's rotation DOFs (once per force
        evaluation, after it; ``kept``: as the compiled loop turned them)."""
        if self.space == 3:
            theta = q[:self._n_bonded, 3:]
            if kept:
                self.orientation.keep(theta)
            else:
                self._orientation(q).advance(theta)

    def set_temperature(self, T_node, count=True) -> float:
        """The beams' rest lengths and strengths at the model nodes'
        temperatures ``T_node`` (see :meth:`BondForce.set_temperature`; the
        bending energy does not change with the rest length)."""
        work = super().set_temperature(T_node, count)
        self.beams.L0[:] = self.L0
        if self.break_strain is not None:
            self.beams.tension[:] = self.limit
            self.beams.shear[:] = self._shear_ratio * self.limit
        return work

    def internal(self, u_vec, out_vec):
        """out = f_int(u): forces and torques of the beams (compiled loop; a
        beam beyond its strength breaks first), plus the carried bonds'
        linear operator and the contacts'."""
        q, n = self.displacements(u_vec), self.n_held
        if self.operator is not None:
            self.operator.mult(u_vec, out_vec)
        out = out_vec.getArray().reshape(n, self.dim)
        snapped = self._beam_forces(self.beams, q, out, n, self.operator is not None,
                                    self._snapped, self._mode)
        if snapped:
            self._break_beams(self._snapped[:snapped].copy(), self._mode[:snapped].copy(), q)
        self._remember(q)
        self._advance(q, kept=True)
        if self.contact is not None:
            self._add_contact(u_vec, q, out)

    def _break_beams(self, which, mode, q):
        """Record beams ``which`` as broken at ``q`` in ``mode`` (1 tension, 2
        shear): time, midpoint, the strain that broke it (the outer fibre's,
        or |V| / (E_b A)) and its limit, temperature (NaN without heat),
        mode, the energy it released (the mean of this evaluation's and the
        last one's), particles.  The energy counts once: on the piece owning
        its first particle."""
        sub = self.beams.subset(which)
        if self.space == 2:
            now, before = self._split(q), lambda v: sub.energies(*self._split(v))
        else:       # the loop's frames at q; at the last evaluation's q (_released's v), the
            now = (q[:, :3], self._R)          # orientations not yet kept
            before = lambda v: sub.energies(v[:, :3], matrices(self.orientation.quat))  # noqa: E731
        fibre, slip, t_limit, s_limit = sub.failure(*now)
        shear = mode == 2
        strain, limit = np.where(shear, slip, fibre), np.where(shear, s_limit, t_limit)
        energy = self._released(sub.energies(*now), before)
        i, j = self.i[which], self.j[which]
        s = self.space
        mid = 0.5 * ((self.X[i] + self.X[j]) + (q[i, :s] + q[j, :s]))
        first = i < self.part.layout.n_owned
        self.released += float(energy[first].sum())
        temp = self.T[which] if self.T is not None else np.full(which.size, np.nan)
        for w, row in zip(which[first].tolist(),
                          np.column_stack([mid, strain, limit, temp, mode,
                                           energy])[first].tolist()):
            self.broken.append((self.now, *row, int(self.nodes[w, 0]), int(self.nodes[w, 1])))

    def restore_broken(self, rows):
        """Beams broken before a checkpoint (rows of :meth:`_break_beams`, any
        rank layout): broken again here, their records and the energy they
        held on the piece that owns their first particle."""
        width = 8 + self.space
        rows = np.asarray(rows, dtype=float).reshape(-1, width) if len(rows) else \
            np.zeros((0, width))
        pairs = {(int(a), int(b)) for a, b in rows[:, -2:].astype(np.int64).tolist()}
        key = zip(self.nodes[:, 0].tolist(), self.nodes[:, 1].tolist())
        self.alive[:] = [pair not in pairs for pair in key]
        owned = set(self.part.layout.owned.tolist())
        mine = [r for r in rows.tolist() if int(r[-2]) in owned]
        self.broken = [tuple(r[:-2]) + (int(r[-2]), int(r[-1])) for r in mine]
        self.released = float(sum(r[-3] for r in mine))

    def orientations(self):
        """3D: the rows (id, quaternion, theta at it) of the particles this
        piece owns (a checkpoint's; None in 2D, where theta is the
        orientation)."""
        if self.space == 2 or self.orientation is None:
            return None
        return self.orientation.rows(self.ids[:self.part.layout.n_owned])

    def restore_orientations(self, rows):
        """A checkpoint's orientations (rows of :meth:`orientations`, all
        pieces'): :meth:`resume` takes them."""
        self._pending = rows

    def resume(self, part):
        """After a restore (collective): as :class:`BondForce`'s, and in 3D the
        particles' orientations are the checkpoint's (exp(theta) for one
        written before they were kept)."""
        super().resume(part)
        if self.space == 3:                # (_u_last: the restored q of held and bond ghosts)
            self.orientation = Orientation.from_rows(self._u_last[:, 3:],
                                                     self.ids[:self._n_bonded], self._pending)
            self._pending = ()

    def rotation_vectors(self):
        """3D: the rotation vectors (angle at most pi) of the owned particles'
        orientations at the last evaluation (the fields' rotation; None in 2D)."""
        if self.space == 2 or self.orientation is None:
            return None
        return vectors(self.orientation.quat[:self.part.layout.n_owned])

    def reference_internal(self, u_vec, out_vec):
        """The live beams' forces in numpy (:class:`~solver.partitions.beam_bond.BeamBonds`;
        nothing breaks here)."""
        q, n = self.displacements(u_vec), self.n_held
        force, torque = self.beams.forces(*self._split(q))
        self._remember(q)
        self._advance(q)
        out = np.column_stack([force, torque])[:n]
        if self.contact is not None:
            self._add_contact(u_vec, q, out)
        if self.operator is not None:
            self.operator.mult(u_vec, out_vec)
            out_vec.getArray()[:] += out.ravel()
        else:
            out_vec.getArray()[:] = out.ravel()

    def virial(self, u, bonds, c) -> float:
        """sum f_c d_c over the live ``bonds`` at ``u`` [n, dof]: f the beam's
        force on its first particle (axial and shear)."""
        return self.beams.virial(*self._split(u), bonds, c)

    def energy(self, part) -> float:
        """Strain energy of the live beams, half to each end this piece owns,
        plus the other elements' (owned rows)."""
        q = self.displacements(part.u)
        e = np.where(self.alive, self.beams.energies(*self._split(q)), 0.0)
        total = float(np.dot(e, self._share()))
        if self.contact is not None:             # of the last force evaluation (one piece)
            total += self.contact.energy
        if self.operator is not None:
            n = part.n_energy
            self.operator.mult(part.u, part.r)
            total -= 0.5 * float(np.dot(part.U[:n], part.R[:n]))
        return total
