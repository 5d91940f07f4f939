"""One registry of coupling schemes (``coupling.scheme``), GC included.

Every scheme class has the same protocol: ``treatments(scene)`` (the
external-data treatment of every partition), ``build(scene, model, comm,
say)`` (a scheme ready to step on this rank, with ``parts``, ``layouts``,
``freqs`` and ``exchanges``), then ``initialise(model)``, ``synchronise()``
(externals from their owners, as after a step: restarts and the step-matrix
analysis), ``step(t0)`` and ``describe()``.
"""
from __future__ import annotations

# What each coupling.scheme is, for users (``python -m solver schemes``).
ABOUT = {
    "overlap": "Li et al.'s (2023) concurrent scheme: the partitions advance side by side from the same "
               "system-step state, overlap by one layer of external nodes and exchange "
               "displacement, velocity and acceleration once per system step",
    "staggered": "Ma et al.'s (2018) explicit-implicit scheme: the explicit partition sub-cycles over "
                 "the system step, then the implicit partition solves its step with the "
                 "explicit side's accelerations prescribed on the interface",
    "gc": "the Gravouil-Combescure baseline: the interface nodes are duplicated with half "
          "their mass and Lagrange multipliers keep the copies' velocities equal at every fine "
          "step (first order for ratios above 1)",
    "conserving": "energy-conserving multi-time-step coupling (docs/conserving.md): the fine "
                  "side follows the coarse side's straight displacement path on a shared "
                  "interface, and a discrete energy is conserved to round-off",
    "transition": "Zhang et al.'s (2009) transition zone (docs/transition.md): the lattice's outer "
                  "particle layers lie in a band of coarse cells and move with them; the dem "
                  "partition sub-cycles over the band's motion, then the fem partition steps "
                  "with the particles' forces",
}

# What each coupling.scheme accepts (checked in Scene.validate and at launch).
SUPPORT = {
    "overlap": "network and continuum models; any number of partitions, each fem+explicit, "
               "fem+implicit or dem+verlet; any number of ranks; external: taylor, layers, "
               "literal",
    "staggered": "network and continuum models; exactly two partitions: fem+implicit with the "
                 "largest ratio, and fem+explicit or dem+verlet; any number of ranks; external "
                 "(of the explicit side): taylor, layers, literal",
    "gc": "network models only (springs; not continua, heat or lattices); exactly two "
          "partitions: fem+implicit with the largest ratio and fem+explicit; 1 rank",
    "conserving": "network and continuum models without heat and with linear bonds; exactly "
                  "two partitions on a node-matching interface: fem+implicit (average "
                  "acceleration) with the largest ratio and fem+explicit (central difference) "
                  "or dem+verlet; 1 or 2 ranks (one per side)",
    "transition": "continuum models with model.lattice.transition: one fem+explicit partition "
                  "with the largest ratio (the FE step) and one dem+verlet partition; any number "
                  "of ranks; external: taylor",
}

# The step each scheme allows (the guard refuses a step beyond it before stepping).
LIMIT = {
    "overlap": "each explicit partition's own limit (omega_max h < 2 on its step); an implicit "
               "partition has none alone, but coupled beyond about 1.4 x the explicit critical "
               "step it can go unstable (a warning is printed before stepping; the energy "
               "guard stops a blow-up)",
    "staggered": "the explicit partition's own limit; the implicit one has none alone, but "
                 "coupled beyond about 1.4 x the explicit critical step it can go unstable (a "
                 "warning is printed before stepping; the energy guard stops a blow-up)",
    "gc": "the fine partition's own explicit limit, its interface copies at half mass (the "
          "guard checks that); beyond it nothing is proven: on some chains the coupled step "
          "grows slowly at ratios 2-4 even below that limit (spectral radius up to 1.004, "
          "docs/conserving.md); the energy guard stops a blow-up",
    "conserving": "stable at any ratio whenever each side is: the fine side's own explicit "
                  "limit with the interface nodes at full mass; the coarse side none",
    "transition": "the FE step: omega_max fdt below a bound set by coupling.band_motion "
                  "({band_limits}); the dem partition's own limit; when the dem partition "
                  "sub-cycles, a damping ratio of at least 0.01 at the DEM's highest frequency "
                  "(damping.beta)",
}


# Schemes whose partitions take coupling.external (the others keep their own
# interface treatment) and the most ranks a scheme runs on (absent: any).
USES_EXTERNAL = {"overlap", "staggered", "transition"}
MAX_RANKS = {"gc": 1, "conserving": 2}


def scheme_class(name: str):
    # lazy: cli schemes reads these tables without the scheme modules
    from solver.coupling.system_step import ConcurrentOverlap, Staggered, TransitionZone
    from solver.coupling.gc import GravouilCombescure
    from solver.coupling.conserving import Conserving
    return {"overlap": ConcurrentOverlap, "staggered": Staggered, "gc": GravouilCombescure,
            "conserving": Conserving, "transition": TransitionZone}[name]
