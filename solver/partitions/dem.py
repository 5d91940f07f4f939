"""DEM partition: particles in structure-of-arrays fields, bonds between them.

Particles are the partition's held nodes; their named fields (like DMSwarm's)
are views of the partition state.  Bonds are linear springs: scalar springs
of a network (j = -1 for the ground), or the central bonds of a lattice
(k n n^T blocks, see :mod:`solver.model.lattice`).  Bond forces are applied through
the bond operator, the linear map x -> sum of bond forces, assembled once from
the bonds the partition holds (one MatMult per step), behind the force
interface of :mod:`solver.partitions.force`.
"""
from __future__ import annotations

import numpy as np

from solver.laws import BOND_GEOMETRIES
from solver.partitions.force import LinearForce
from solver.partitions.partition import Partition
from solver.model.continuum import BondStiffness
from solver.model.dilatation import StarStiffness
from solver.partitions.beam_force import BeamBondForce
from solver.partitions.bonds import BondForce


class DemPartition(Partition):
    method = "dem"

    def build_force(self, model, layout):
        self.force_model = model                 # (its contact settings: the stability bound)
        n_p, dof = layout.n_held, self.dof
        # [particle, component] views; with differing DOF counts, flat views and
        # each particle's first DOF
        shape = (n_p, dof) if dof is not None else (-1,)
        self.fields = {
            "mass": self.mass.reshape(shape),
            "displacement": self.U.reshape(shape),
            "velocity": self.V.reshape(shape),
            "acceleration": self.A.reshape(shape),
            "global_id": layout.held,
        }
        if dof is None:
            self.fields["first_dof"] = self.starts
        blocks = model.bond_blocks(self.whole_held())
        B = self.operator(blocks, scale=-1.0)
        B.setName(f"{self.name}_bonds")
        self.built += [f"particles {n_p} ({layout.n_owned} owned), fields "
                      f"{', '.join(self.fields)}",
                      f"bond operator {B.getSize()[0]}x{B.getSize()[0]} (type {B.getType()}, "
                      f"block size {B.getBlockSize()})"]
        if model.lattice is None or not BOND_GEOMETRIES[model.lattice.geometry].current:
            return LinearForce(B, blocks)
        return self._nonlinear(model, blocks, B)

    @staticmethod
    def _spread(force, lat) -> str:
        """The log's words on the strengths' Weibull spread ("" without one)."""
        if lat.weibull is None:
            return ""
        here = (f"; this piece's {force.limit.min():.3g} to {force.limit.max():.3g}"
                if force.limit.size else "")
        return (f" x a Weibull factor (modulus {lat.weibull[0]:g}, mean 1, seed "
                f"{lat.weibull[1]}{here})")

    def _nonlinear(self, model, blocks, B):
        """Lattice bonds from the current configuration (and breakage); the other
        elements keep a linear operator; B (all of them, at rest) is the tangent."""
        lattice = [(c, k) for c, k in blocks if isinstance(k, BondStiffness)]
        # the volumetric term's stars: in the tangent B only (the force evaluates them)
        others = [(c, k) for c, k in blocks if not isinstance(k, (BondStiffness, StarStiffness))]
        conn = np.concatenate([c for c, _ in lattice]) if lattice else np.zeros((0, 2), np.int64)
        stiff = lattice[0][1] if lattice else None
        if len(lattice) > 1:
            stiff = type(stiff).joined([k for _, k in lattice], conn)
        other = self.operator(others, scale=-1.0) if others else None
        contact = model.contact
        lat = model.lattice
        if lat.bending is not None:
            force = BeamBondForce(self, (conn, stiff), other, others, B, lat.break_strain,
                                  lat.weibull, lat.shear, contact, model.mass, model.heat)
            what = ""
            if lat.break_strain is not None:
                ratio, friction = lat.shear
                what = (f", breaking in tension beyond an outer-fibre strain of "
                        f"{lat.break_strain:g} or in shear beyond {ratio:g} x that (+ "
                        f"{friction:.3g} x compression){self._spread(force, lat)}")
            self.built.append(f"{len(force.k)} beam bonds between rotating particles (axial, "
                              f"shear, bending; current configuration){what}"
                              f"{self._contact_words(contact, ' (turning the particles)')}"
                              f"{self._ghost_words(force)}")
            return force
        force = BondForce(self, (conn, stiff), other, others, B, lat.break_strain,
                          contact, model.heat, model.mass, lat.weibull, lat.dilatation)
        strain = (f", breaking beyond strain {lat.break_strain:g}"
                  if lat.break_strain is not None else "")
        if lat.dilatation is not None:
            strain += (", a volumetric term on each particle's bonds (tensions (P_i + P_j) / L0, "
                       "P = c theta dim / n)")
        strain += self._spread(force, lat) + self._contact_words(contact)
        self.built.append(f"{len(force.k)} lattice bonds from the current configuration"
                          f"{strain}{self._ghost_words(force)}")
        return force

    @staticmethod
    def _contact_words(contact, turning="") -> str:
        """The log's words on the particles' contact ("" without it)."""
        if contact is None:
            return ""
        law, zeta, mu = contact.law, contact.damping_ratio, contact.friction
        dash = (f", dashpot ratio {zeta:g}" if zeta else "") + \
            (f", friction {mu:g}" if mu else "")
        if contact.history:
            dash += (f" on shear springs k_t = {contact.tangential_stiffness:.4g} k kept per "
                     f"pair (Cundall-Strack){turning}")
            if contact.rolling_friction:
                dash += (f", rolling resistance {contact.rolling_friction:g} on rolling springs "
                         "k_r = k_t R*^2")
        elif mu:
            dash += f" (viscous, no shear history){turning}"
        size = f"radius {contact.radius:g} m"
        if contact.radii is not None:              # a random packing's spread radii
            size = f"radii up to {contact.radius:g} m, the packing's, r_i + r_j at touch"
        return (f"; {law.name} contact of unbonded particles ({size}, "
                f"stiffness {law.stiffness:g} {law.unit}{dash}, neighbour search with skin "
                f"{contact.skin:g} m)")

    @staticmethod
    def _ghost_words(force) -> str:
        """The log's words on ghost and halo particles ("" without them)."""
        ghosts = f", {force.n_ghosts} ghost particles" if force.n_ghosts else ""
        if force.halo is not None:
            ghosts += (f", contact halo {force.n_halo} particles (those within 2r + skin of "
                       "its own, renewed with the search)")
        return ghosts
