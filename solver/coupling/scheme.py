"""The declared interface of a coupling scheme (``coupling.scheme``).

A scheme is one subclass of :class:`Scheme`.  Its class body declares what
the scheme is (``name``, ``summary``, ``about``, ``supports``, ``limit``,
``uses_external``, ``max_ranks``) and its rules, as classmethods the other
stages call instead of testing the scheme's name:

- ``validate(scene)``: the scene-level rules (Scene.validate calls it; SceneError);
- ``check_launch(scene, size)``: the launch rules (rank counts; LaunchError);
- the stability rule the guard (:mod:`solver.partitions.stability`) applies:
  ``holds_externals(scene, spec)``, ``step_limit(scene, spec, limit)``, and
  after building ``built_problems(scene, freqs)`` (with ``dropped``: what
  running anyway gives up) and ``refusal_context(scene, freqs)``;
- ``treatments(scene)`` and ``build(scene, model, comm, say)``: the external-data
  treatment of every partition, and the scheme ready to step on this rank
  (schemes built by the partitions stage also take ``assignment``: the ranks
  to build on, :mod:`solver.driver.balance`).

Defining the class registers it (:mod:`solver.scene.registry`).  A built scheme
has ``parts``, ``owned_counts`` (every partition's owned nodes), ``freqs``,
``model``, ``exchanges``, ``clocks`` and ``assignment`` (the partitions
stage's rank assignment; None for a scheme that places its partitions
itself) and steps with ``initialise(model)``,
``synchronise()``, ``step(t0)``, ``describe()``, ``memory()`` and
``restore_memory(memory)``.
"""
from __future__ import annotations

from solver.errors import LaunchError
from solver.partitions import integrators
from solver.scene import registry
from solver.scene.schema import fail

FACTS = ("name", "summary", "about", "supports", "limit", "uses_external", "max_ranks")


class Scheme:
    """Base of every coupling scheme; a subclass that sets ``name`` in its own
    class body is registered under it."""

    name: str                  # the value of coupling.scheme
    summary: str               # one clause for the coupling.scheme key's documentation
    about: str                 # what it is, for users (python -m solver schemes)
    supports: str              # models, partitions, ranks and external treatments it takes
    limit: str                 # the step it allows (the guard's rule, in words)
    uses_external: bool        # whether its partitions take coupling.external
    max_ranks: int | None      # the most ranks it runs on (None: any)
    dropped = "running anyway"  # what running anyway gives up when built_problems are waived
    levels = False             # whether partitions: auto (one levelled partition) may use it
    assignment = None          # a built scheme's ranks.Assignment (None: placed by the scheme)
    rides = True               # whether a cheap partition may run on a rank of another's
    #                            (ranks.assign): its sides need not have ranks of their own
    hands_over = False         # whether build takes the whole model as a partitioning.Whole

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__:
            missing = [f for f in FACTS if not hasattr(cls, f)]
            if missing:
                raise TypeError(f"coupling scheme {cls.__dict__['name']!r} does not declare "
                                f"{', '.join(missing)}")
            registry.register(cls)

    # ------------------------------------------------------------ scene rules
    @classmethod
    def validate(cls, scene):
        """The scene-level rules of this scheme (SceneError naming the key).
        Here: a transition band and its band motion belong to the transition scheme."""
        if scene.coupling.band_motion != "predictor":
            fail("coupling.band_motion", f"{scene.coupling.band_motion}: only the transition "
                 "scheme moves a band")
        if banded(scene):
            fail("coupling.scheme", f"{cls.name}: a transition band "
                 "(model.lattice.transition) couples with scheme transition")

    @classmethod
    def check_launch(cls, scene, size: int):
        """Refuse a launch on ``size`` ranks the scheme cannot run on (LaunchError)."""
        most = cls.max_ranks
        if most is not None and size > most:
            span = "1 rank" if most == 1 else "1 or 2 ranks" if most == 2 else f"1 to {most} ranks"
            raise LaunchError(f"coupling.scheme {cls.name} runs on {span}, not {size}")

    # --------------------------------------------------------- stability rule
    @classmethod
    def holds_externals(cls, scene, spec) -> bool:
        """Whether partition ``spec``'s external nodes are held still in its
        stability check (else they count with their masses)."""
        return False

    @classmethod
    def step_limit(cls, scene, spec, limit: float) -> tuple[float, str]:
        """(the largest omega_max * h partition ``spec`` may step at, given its
        integrator's ``limit``; the reason appended to a refusal, or '')."""
        return limit, ""

    @classmethod
    def built_problems(cls, scene, freqs) -> list[str]:
        """Refusals once every partition's frequency is known (``freqs``: name ->
        (Frequency, critical step)); waived with a warning by guard.stable_step false."""
        return []

    @classmethod
    def refusal_context(cls, scene, freqs) -> str | None:
        """Text appended to a step refusal (``freqs``: the critical steps known so far)."""
        return None

    # --------------------------------------------------------------- building
    @staticmethod
    def treatments(scene) -> list[str]:
        """The external-data treatment of every partition."""
        raise NotImplementedError

    @classmethod
    def build(cls, scene, model, comm, say):
        """The scheme ready to step on this rank."""
        raise NotImplementedError

    def memory(self) -> dict:
        """What a checkpoint keeps of the scheme beyond its partitions' states
        (name -> array, this rank's part): none."""
        return {}

    def restore_memory(self, memory: dict):
        """Put :meth:`memory`'s arrays (merged over ranks) back after synchronise()."""


def banded(scene) -> bool:
    """Whether the scene's model has a transition band (model.lattice.transition)."""
    model = scene.model
    return model.kind == "continuum" and model.lattice is not None and bool(model.lattice.transition)


def two_sides(scene, name: str):
    """(the implicit partition, the other one) of scheme ``name`` that couples
    exactly two partitions, the implicit one with the largest ratio (SceneError
    otherwise)."""
    parts = scene.partitions
    implicit = [p for p in parts if integrators.kind(p).implicit]
    if len(parts) != 2 or len(implicit) != 1:
        fail("coupling.scheme", f"{name} couples exactly two partitions, one with "
             f"integrator implicit ({len(parts)} partitions, {len(implicit)} implicit given)")
    if implicit[0].ratio != scene.system_ratio:
        fail("coupling.scheme", f"{name}: the implicit partition '{implicit[0].name}' takes "
             "the large step, so its ratio must be the largest")
    return implicit[0], next(p for p in parts if p is not implicit[0])
