"""What every model is: the declared interface of a network :class:`Model` and
a :class:`ContinuumArrays`, and the optional features a model may carry.

The later stages (partitions, coupling, driver) use a model only through
:class:`ModelInterface`.  They ask what kind of model it is by name, never by
probing attributes:

- ``model.kind``: ``"network"`` (masses and springs, no geometry) or
  ``"continuum"`` (a mesh: ``cells``, ``material_D`` as well);
- ``model.points``: node coordinates [n_nodes, space], None for a network
  (its nodes are masses, not places);
- one field per optional feature, None when the model has none:

  ``shells``  :class:`Shells` (6 DOFs per node, rotary inertia);
  ``lattice`` :class:`Lattice` (bonds and the bond law of ``model.lattice``);
  ``contact`` the contact settings of ``model.lattice.contact``
  (:func:`solver.model.continuum.contact_of`), carried as they are;
  ``heat``    the :class:`solver.model.heat.Conduction` of scene key ``heat``;
  ``zone``    the :class:`solver.model.transition.Transition` of
  ``model.lattice.transition``;
  ``rotary``  [n_nodes] rotational inertia of the DOFs past the spatial ones
  of nodes that rotate without shells (particles joined by beam bonds:
  ``model.lattice.bond: beam``; the other nodes' rotations are fixed).

A network has none of the features: it declares them as class attributes
(None), so its constructor stays the arrays of its masses and springs.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from solver.model.dofmap import DofMap
from solver.model.graph import Graph

if TYPE_CHECKING:
    from solver.model.heat import Conduction
    from solver.model.transition import Transition

FEATURES = ("shells", "lattice", "contact", "heat", "zone", "rotary")


@dataclass(frozen=True)
class Shells:
    """Shell surfaces (``model.material.kind: shell`` or ``model.shells``):
    every node has 6 DOFs (u_x, u_y, u_z, theta_x, theta_y, theta_z)."""

    inertia: np.ndarray          # [n_nodes] rotary inertia of each node's rotations (DOFs 3-5)
    elements: str = ""           # what was built, for the log: "256 triangles (...), ..."


@dataclass(frozen=True)
class Lattice:
    """The lattice of ``model.lattice`` on the model's nodes: the elements dem
    partitions hold besides the body's cells, and the law of its bonds."""

    bonds: tuple = ()            # (i, j, k) central bonds between model nodes
    overlap_cells: list = ()     # (family, conn, Ke) of mesh cells both sides share
    carried: list = ()           # ("bond", conn, RankOneBonds): bonds of band particles on nodes
    geometry: str = "linear"     # bonds: linear (small strain) or nonlinear (current configuration)
    break_strain: float | None = None   # bonds break beyond this strain (nonlinear), or never
    weibull: tuple | None = None        # (modulus, seed) of the strengths' spread, or None
    bending: np.ndarray | None = None   # bond: beam, k_b of each of ``bonds`` (particles rotate)
    shear: tuple | None = None          # breakable beams: (shear_ratio, tan friction angle)
    dilatation: object = None           # the volumetric term (solver.model.dilatation), or None


@runtime_checkable
class ModelInterface(Protocol):
    """What partitions, schemes and the driver may use of any model.  DOF
    ``c`` of node ``n`` has index ``dofmap.offsets[n] + c`` in every model
    vector; blocks are lists of (conn [n_el, k] global node ids, Ke [n_el]
    blocks over the DOFs of those nodes)."""

    kind: str                    # "network" | "continuum"
    dof: int                     # DOFs per node (uniform models)
    mass: np.ndarray             # [n_nodes] lumped
    fixed: np.ndarray            # [n_dofs] bool
    loads: tuple                 # PointLoads
    u0: np.ndarray               # [n_dofs]
    v0: np.ndarray               # [n_dofs]
    points: np.ndarray | None    # [n_nodes, space], None for a network
    notes: tuple                 # what reading the model data changed, logged
    shells: Shells | None
    lattice: Lattice | None
    contact: tuple | None
    heat: Conduction | None
    zone: Transition | None
    rotary: np.ndarray | None
    gravity: np.ndarray | None   # body acceleration [space] on every node's mass, or None
    motions: tuple               # prescribed motions (solver.model.prescribed.Motion), or ()

    @property
    def n_nodes(self) -> int: ...

    @property
    def n_dofs(self) -> int: ...

    @property
    def dofmap(self) -> DofMap: ...

    def graph(self) -> Graph:
        """Adjacent nodes of every node."""

    def share(self, nodes, body_cells: bool = True) -> "ModelInterface":
        """The model with only the elements that touch ``nodes`` (``body_cells``
        False: without the body's cells, for a rank that steps no fem partition)."""

    def stiffness_blocks(self, held: np.ndarray) -> list:
        """Blocks of the elements a fem partition holding ``held`` assembles."""

    def bond_blocks(self, held: np.ndarray) -> list:
        """Blocks of the elements a dem partition holding ``held`` applies."""


def features(model) -> tuple[str, ...]:
    """Names of the optional features ``model`` carries (of :data:`FEATURES`)."""
    return tuple(name for name in FEATURES if getattr(model, name) is not None)
