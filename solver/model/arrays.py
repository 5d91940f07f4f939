"""The structure as arrays: nodes with lumped masses, linear springs, loads.

Pure numpy.  Nodes carry the DOFs of the model's ``dofmap`` (1 per node for
networks, dim for continua; counts may differ between nodes); DOF ``c`` of
node ``n`` has index ``dofmap.offsets[n] + c`` in every model vector.  Springs are stored as index arrays with
``GROUND`` (-1) for a fixed end, so partitions can select theirs with numpy.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar

import numpy as np

from solver.model.dofmap import DofMap
from solver.model.graph import Graph
from solver.model.interface import Lattice, Shells
from solver.model.loads import PointLoad, load_function
from solver.scene import Scene
from solver.model import continuum, data as model_data


@dataclass(frozen=True)
class Model:
    """Whole-structure data shared by all partitions.

    mass: [n_nodes]; spring_i, spring_j: [n_springs] node ids (GROUND = -1);
    spring_k: [n_springs]; u0, v0: [n_dofs].  ``dof`` DOFs per node, or
    ``dof_counts`` [n_nodes] when nodes differ (see :mod:`solver.model.dofmap`).
    A network has no geometry and none of the optional features
    (:mod:`solver.model.interface`): they are class attributes, None.
    """

    dof: int
    mass: np.ndarray
    spring_i: np.ndarray
    spring_j: np.ndarray
    spring_k: np.ndarray
    loads: tuple[PointLoad, ...]
    u0: np.ndarray
    v0: np.ndarray
    dof_counts: np.ndarray | None = None

    kind: ClassVar[str] = "network"
    points: ClassVar[None] = None           # nodes are masses, not places
    notes: ClassVar[tuple] = ()
    shells: ClassVar[Shells | None] = None
    lattice: ClassVar[Lattice | None] = None
    contact: ClassVar[tuple | None] = None
    heat: ClassVar[object] = None
    zone: ClassVar[object] = None
    rotary: ClassVar[None] = None
    gravity: ClassVar[None] = None
    motions: ClassVar[tuple] = ()

    @property
    def n_nodes(self) -> int:
        return self.mass.size

    @cached_property
    def dofmap(self) -> DofMap:
        if self.dof_counts is not None:
            return DofMap(self.dof_counts)
        return DofMap.uniform(self.n_nodes, self.dof)

    @property
    def fixed(self) -> np.ndarray:
        """Fixed DOFs (networks fix through ground springs: none)."""
        return np.zeros(self.n_dofs, bool)

    @property
    def n_dofs(self) -> int:
        return self.dofmap.n_dofs

    def graph(self) -> Graph:
        """Adjacent nodes of every node (ground excluded)."""
        free = (self.spring_i >= 0) & (self.spring_j >= 0)
        return Graph.from_pairs(self.n_nodes, self.spring_i[free], self.spring_j[free])

    def share(self, nodes, body_cells: bool = True) -> "Model":
        """This model with only the springs that touch ``nodes`` (what a rank
        holding those nodes assembles; a network has no cells: ``body_cells``
        changes nothing)."""
        inh = np.zeros(self.n_nodes + 1, bool)           # slot -1: the ground
        inh[nodes] = True
        keep = inh[self.spring_i] | inh[self.spring_j]
        return dataclasses.replace(self, spring_i=self.spring_i[keep], spring_j=self.spring_j[keep],
                                   spring_k=self.spring_k[keep])

    def springs_within(self, held: np.ndarray):
        """Springs whose both ends are in ``held`` (ground counts as held), as
        local indices (li, lj with -1 for ground) and stiffness."""
        local = np.full(self.n_nodes + 1, -2, dtype=np.int64)   # slot -1 -> ground
        local[held] = np.arange(held.size)
        local[-1] = -1
        li, lj = local[self.spring_i], local[self.spring_j]
        keep = (li != -2) & (lj != -2)
        return li[keep], lj[keep], self.spring_k[keep]

    def stiffness_blocks(self, held: np.ndarray) -> list:
        """Block sets (global node ids) of the springs whose ends are held:
        [[k, -k], [-k, k]] between nodes, [[k]] to the ground."""
        inh = np.zeros(self.n_nodes + 1, bool)          # slot -1: the ground is always held
        inh[held] = True
        inh[-1] = True
        si, sj, k = self.spring_i, self.spring_j, self.spring_k
        keep = inh[si] & inh[sj]
        both = keep & (si >= 0) & (sj >= 0)
        ground = keep & ((si < 0) != (sj < 0))
        pair = np.array([[1.0, -1.0], [-1.0, 1.0]])
        out = [(np.stack([si[both], sj[both]], axis=1), k[both][:, None, None] * pair)]
        if ground.any():
            end = np.where(si[ground] >= 0, si[ground], sj[ground])
            out.append((end[:, None], k[ground][:, None, None] * np.ones((1, 1))))
        return out

    bond_blocks = stiffness_blocks          # a dem partition of a network applies the springs

    def bond_triplets(self, held: np.ndarray):
        """COO stiffness of the springs a dem partition holding ``held`` applies."""
        return spring_triplets(*self.springs_within(held))

    def stiffness_triplets(self, held: np.ndarray):
        """COO (rows, cols, values) of the stiffness over the held nodes."""
        li, lj, k = self.springs_within(held)
        return spring_triplets(li, lj, k)

    def full_stiffness(self) -> np.ndarray:
        """Dense stiffness of the whole structure (for references and checks)."""
        r, c, v = self.stiffness_triplets(np.arange(self.n_nodes))
        K = np.zeros((self.n_dofs, self.n_dofs))
        np.add.at(K, (r, c), v)
        return K


def spring_triplets(li, lj, k):
    """COO entries of 1-DOF springs between local nodes ``li``, ``lj``; an end
    of -1 is fixed, so only the other end's diagonal entry remains."""
    both = (li >= 0) & (lj >= 0)
    gi = (li >= 0) & (lj < 0)
    gj = (lj >= 0) & (li < 0)
    i2, j2, k2 = li[both], lj[both], k[both]
    rows = np.concatenate([i2, j2, i2, j2, li[gi], lj[gj]])
    cols = np.concatenate([i2, j2, j2, i2, li[gi], lj[gj]])
    vals = np.concatenate([k2, k2, -k2, -k2, k[gi], k[gj]])
    return rows.astype(np.int64), cols.astype(np.int64), vals


def dof_masses(model, held) -> np.ndarray:
    """The lumped mass of every DOF of nodes ``held``: the node's mass, or for
    the rotations of shell nodes (6 DOFs) and of rotating particles its rotary
    inertia."""
    m = np.repeat(model.mass[held], model.dofmap.counts[held])
    if model.shells is not None:
        m = m.reshape(-1, 6)
        m[:, 3:] = model.shells.inertia[held][:, None]
        m = m.ravel()
    elif model.rotary is not None:           # rotating particles: DOFs past the spatial ones
        m = m.reshape(-1, model.dof)
        m[:, model.points.shape[1]:] = model.rotary[held][:, None]
        m = m.ravel()
    return m


def build(scene: Scene, layers=None, store=None):
    """Arrays of the scene's model (network or continuum).  ``layers``: external
    layers of every partition, as the coupling scheme's treatments give them
    (a lattice reaches as far as its dem partitions' layers; default 1).
    ``store``: the run's :class:`~solver.model.data.ModelData` (None: read afresh)."""
    if scene.model.kind == "continuum":
        reach = max([n for n, p in zip(layers or [], scene.partitions) if p.method == "dem"]
                    or [1])
        return continuum.build(scene, reach, store)
    return build_network(scene, store)


def build_network(scene: Scene, store=None) -> Model:
    """Arrays of the scene's network model."""
    net = (store if store is not None else model_data.ModelData()).read(scene.model)
    n, dof = net.mass.size, 1
    u0, v0 = np.zeros(n), np.zeros(n)
    for node, value in scene.initial.displacement.items():
        u0[node] = value
    for node, value in scene.initial.velocity.items():
        v0[node] = value
    loads = tuple(PointLoad(l.node * dof + (l.component or 0), load_function(l)) for l in scene.loads)
    return Model(dof=dof, mass=net.mass, spring_i=net.spring_i, spring_j=net.spring_j,
                 spring_k=net.stiffness, loads=loads, u0=u0, v0=v0)
