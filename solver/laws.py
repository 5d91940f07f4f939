"""Contact laws and bond geometries as declared objects, registered by name.

A stage-free module (numpy only, like :mod:`solver.errors`): the scene keys
``model.lattice.contact.law`` and ``model.lattice.geometry`` take their
allowed values from these registries, the model builds the law object
(:func:`solver.model.continuum.contact_of`), and the partitions evaluate it
(:mod:`solver.partitions.contact`, the stable step bound in
:mod:`solver.partitions.stability`).  As in LIGGGHTS (one ``normal_model_*``
header per law) and JAX-MD (one energy function per potential), a contact law
is one small class: its parameter, the normal force f(d) of the overlap d,
its tangent df/dd, its energy (f = dE/dd), and the stiffness the critical
step bound uses, valid for overlaps up to ``bound_overlap`` x radius.

To add a law: subclass :class:`ContactLaw` (``name``, ``unit``,
``evaluate``, ``bound``) and decorate it with ``@CONTACT_LAWS.register``.
"""
from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import MutableMapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np


class Registry(MutableMapping):
    """name -> declared class; ``register`` is a class decorator (the class's
    ``name`` attribute is its key).  Iteration keeps the order of registration."""

    def __init__(self, what: str):
        self.what = what
        self._items = {}

    def register(self, cls):
        self[cls.name] = cls
        return cls

    def __setitem__(self, name, cls):
        if getattr(cls, "name", None) != name:
            raise ValueError(f"{self.what} {cls!r} registered as {name!r}: its name is "
                             f"{getattr(cls, 'name', None)!r}")
        self._items[name] = cls

    def __getitem__(self, name):
        return self._items[name]

    def __delitem__(self, name):
        del self._items[name]

    def __iter__(self):
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def choices(self) -> str:
        """The names as the scene docs show them: ``linear | hertz``."""
        return " | ".join(self._items)


CONTACT_LAWS = Registry("contact law")
BOND_GEOMETRIES = Registry("bond geometry")


@dataclass(frozen=True)
class ContactLaw(ABC):
    """A repulsive normal contact law of the overlap d >= 0 of two spheres.

    ``stiffness`` is the law's parameter (in ``unit``); ``evaluate(d)`` gives
    (force f(d), tangent df/dd, energy E(d)) with f = dE/dd, E(0) = 0;
    ``bound(radius)`` the stiffness the stable step bound uses, an upper bound
    of df/dd for overlaps 0 <= d <= ``bound_overlap`` x radius."""

    stiffness: float
    name: ClassVar[str]
    unit: ClassVar[str]
    bound_overlap: ClassVar[float] = math.inf

    @abstractmethod
    def evaluate(self, overlap: np.ndarray):
        """(force, tangent stiffness, energy) of each overlap [n]."""

    @abstractmethod
    def bound(self, radius: float) -> float:
        """The contact stiffness of the step bound for spheres of ``radius``."""

    def force(self, overlap):
        return self.evaluate(np.asarray(overlap, dtype=float))[0]

    def tangent(self, overlap):
        return self.evaluate(np.asarray(overlap, dtype=float))[1]

    def energy(self, overlap):
        return self.evaluate(np.asarray(overlap, dtype=float))[2]


@CONTACT_LAWS.register
@dataclass(frozen=True)
class Linear(ContactLaw):
    """f = k_n d, energy 1/2 k_n d^2 (a spring on the overlap)."""

    name: ClassVar[str] = "linear"
    unit: ClassVar[str] = "N/m"

    def evaluate(self, overlap):
        kn = self.stiffness
        return kn * overlap, np.full(overlap.shape, kn), 0.5 * kn * overlap ** 2

    def bound(self, radius):
        return self.stiffness


@CONTACT_LAWS.register
@dataclass(frozen=True)
class Hertz(ContactLaw):
    """f = k_h d^1.5, energy 2/5 k_h d^2.5, tangent 1.5 k_h d^0.5 (growing with
    d: the step bound takes it at an overlap of 0.1 x radius)."""

    name: ClassVar[str] = "hertz"
    unit: ClassVar[str] = "N/m^1.5"
    bound_overlap: ClassVar[float] = 0.1

    def evaluate(self, overlap):
        kn = self.stiffness
        root = np.sqrt(overlap)
        return kn * overlap * root, 1.5 * kn * root, 0.4 * kn * overlap ** 2 * root

    def bound(self, radius):
        return 1.5 * self.stiffness * np.sqrt(self.bound_overlap * radius)


@dataclass(frozen=True)
class ContactSettings:
    """The contact of a lattice's unbonded particles (``model.lattice.contact``,
    defaults filled): the normal ``law`` (with its stiffness), the spheres'
    ``radius`` [m], the neighbour-list ``skin`` [m], the normal dashpot ratio,
    the Coulomb friction coefficient and its tangential dashpot ratio (the
    viscous regularisation, or the dashpot beside the shear spring);
    ``history``: a tangential spring k_t = ``tangential_stiffness`` x the
    normal tangent stiffness with Coulomb sliding, kept per contact
    (Cundall-Strack) instead of viscous friction alone; ``rolling_friction``
    mu_r: with rotating particles and shear springs, a rolling spring
    k_r = k_t (radius / 2)^2 capped at mu_r (radius / 2) f_n (0: none);
    ``radii``: each model node's radius (a random packing's spread radii,
    ``radius`` then their largest), or None: ``radius`` for all."""

    law: ContactLaw
    radius: float
    skin: float
    damping_ratio: float = 0.0
    friction: float = 0.0
    tangential_damping_ratio: float = 0.5
    history: bool = False
    tangential_stiffness: float = 2.0 / 7.0
    rolling_friction: float = 0.0
    radii: object = field(default=None, compare=False, repr=False)


@BOND_GEOMETRIES.register
@dataclass(frozen=True)
class SmallStrain:
    """Bonds act on the small-strain displacement: one assembled operator."""

    name: ClassVar[str] = "linear"
    current: ClassVar[bool] = False       # evaluated in the current configuration
    breakable: ClassVar[bool] = False


@BOND_GEOMETRIES.register
@dataclass(frozen=True)
class Current:
    """Each bond pulls along its current direction with its current length
    (large rotations exert no force); such bonds may break."""

    name: ClassVar[str] = "nonlinear"
    current: ClassVar[bool] = True
    breakable: ClassVar[bool] = True
