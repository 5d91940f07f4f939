"""One registry of coupling schemes (``coupling.scheme``), GC included.

Every scheme class has the same protocol: ``treatments(scene)`` (the
external-data treatment of every partition), ``build(scene, model, comm,
say)`` (a scheme ready to step on this rank, with ``parts``, ``layouts``,
``freqs`` and ``exchanges``), then ``initialise(model)``, ``synchronise()``
(externals from their owners, as after a step: restarts and the step-matrix
analysis), ``step(t0)`` and ``describe()``.
"""
from __future__ import annotations

# What each coupling.scheme accepts (checked in Scene.validate and at launch).
SUPPORT = {
    "overlap": "any number of partitions, each fem+explicit, fem+implicit or dem+verlet; "
               "any number of ranks; external: taylor, layers, literal",
    "staggered": "exactly two partitions: fem+implicit with the largest ratio, and fem+explicit "
                 "or dem+verlet; any number of ranks; external (of the explicit side): taylor, "
                 "layers, literal",
    "gc": "exactly two partitions: fem+implicit with the largest ratio and fem+explicit; 1 rank",
    "conserving": "exactly two partitions on a node-matching interface: fem+implicit (average "
                  "acceleration) with the largest ratio and fem+explicit (central difference) or "
                  "dem+verlet, linear; 1 or 2 ranks (one per side)",
    "transition": "continuum models with model.lattice.transition: one fem+explicit partition "
                  "with the largest ratio (the FE step) and one dem+verlet partition; any number "
                  "of ranks; external: taylor",
}


# Schemes whose partitions take coupling.external (the others keep their own
# interface treatment) and the most ranks a scheme runs on (absent: any).
USES_EXTERNAL = {"overlap", "staggered", "transition"}
MAX_RANKS = {"gc": 1, "conserving": 2}


def scheme_class(name: str):
    from solver.coupling.system_step import ConcurrentOverlap, Staggered, TransitionZone
    from solver.coupling.gc import GravouilCombescure
    from solver.coupling.conserving import Conserving
    return {"overlap": ConcurrentOverlap, "staggered": Staggered, "gc": GravouilCombescure,
            "conserving": Conserving, "transition": TransitionZone}[name]
