"""The transition-zone scheme (``coupling.scheme: transition``, Zhang et al. 2009).

The lattice's outer particle layers lie in a band of coarse cells and move
with them; the dem partition sub-cycles over the band's motion, then the
explicit fem partition steps with the particles' forces.  The class declares
the scheme's scene rules, its stability rule (the FE step bound per
``coupling.band_motion`` and the damping a sub-cycled coupling needs, numbers
in :mod:`solver.partitions.stability`) and its system step.
"""
from __future__ import annotations

import numpy as np

from solver.coupling.scheme import banded
from solver.coupling.system_step import Staggered
from solver.partitions import stability
from solver.partitions.stability import TRANSITION_OMEGA_H, TRANSITION_XI
from solver.scene.schema import fail, shown


class TransitionZone(Staggered):
    """``coupling.scheme: transition`` (Zhang et al. 2009, Fig. 2): the explicit FE
    partition steps fdt = N dt, the dem partition N steps of dt per FE step.
    (The Staggered machinery names the FE side ``implicit``: it solves last.)

    Per system step: the FE partition predicts u_n+1 = u_n + fdt v_n + fdt^2/2 a_n
    (central difference, Newmark beta 0: its displacement is its predictor);
    the dem partition sub-cycles with the band nodes (its external nodes,
    which carry the band particles) moving as ``coupling.band_motion`` says;
    the particles' state at t_n+1 goes to the FE partition, which evaluates
    the carried bonds (eq. 3) with it and finishes its step; the band nodes'
    new state goes back.  With ``predictor`` (default) the band moves on the
    FE's own path, ``linear`` straight from u_n to u_n+1, both ending on the
    FE's u_n+1; ``velocity`` (u + s v, eq. 4 read literally) and ``hold`` jump
    there.  At N = 1 this is one central-difference step of the whole model
    (docs/transition.md, which also gives the stable steps)."""

    name = "transition"
    summary = ("Zhang et al. (2009), needs model.lattice.transition: the dem partition "
               "sub-cycles over the band's motion, then the explicit fem partition steps with "
               "the particles' forces")
    about = ("Zhang et al.'s (2009) transition zone (docs/transition.md): the lattice's outer "
             "particle layers lie in a band of coarse cells and move with them; the dem "
             "partition sub-cycles over the band's motion, then the fem partition steps "
             "with the particles' forces")
    supports = ("continuum models with model.lattice.transition: one fem+explicit partition "
                "with the largest ratio (the FE step) and one dem+verlet partition whose group "
                "is model.lattice.region; any number of ranks; external: taylor")
    limit = ("the FE step: omega_max fdt below a bound set by coupling.band_motion ("
             + ", ".join(f"{k} {v:g}" for k, v in TRANSITION_OMEGA_H.items())
             + "); the dem partition's own limit; when the dem partition sub-cycles, a damping "
             f"ratio of at least {TRANSITION_XI:g} at the DEM's highest frequency (damping.beta)")
    dropped = "the transition scheme runs without the damping it needs"

    @classmethod
    def validate(cls, scene):
        """A transition band couples one lattice to the FE cells through the
        overlap exchange: the dem partitions hold the core particles (group =
        the lattice region), externals follow the Taylor predictor."""
        if not banded(scene):
            fail("coupling.scheme", "transition: needs a continuum model with "
                 "model.lattice.transition (the band of coarse cells)")
        lat = scene.model.lattice
        if scene.coupling.external != "taylor":
            fail("coupling.external", f"{scene.coupling.external}: a transition band's particles "
                 "follow their cells with the taylor treatment")
        methods = sorted(p.method for p in scene.partitions)
        if methods != ["dem", "fem"]:
            fail("partitions", f"the transition scheme couples one fem and one dem partition "
                 f"(given: {', '.join(methods)})")
        i, fem = next((i, p) for i, p in enumerate(scene.partitions) if p.method == "fem")
        if fem.integrator != "explicit" or fem.ratio != scene.system_ratio:
            fail("partitions", f"transition scheme: fem partition '{fem.name}' must be explicit "
                 f"with the largest ratio ({scene.system_ratio}); its step is the FE step fdt")
        if fem.beta != 0:
            fail(f"partitions[{i}].beta", f"{fem.beta:g}: the transition scheme's FE step is "
                 "central difference (beta: 0), so the band path the particles follow ends on "
                 "the FE's next displacement")
        for p, part in enumerate(scene.partitions):
            if part.method == "dem" and part.group != lat.region:
                fail(f"partitions[{p}].group", f"{shown(part.group)}: with a transition band a dem "
                     f"partition holds the particles of model.lattice.region ({shown(lat.region)})")
            if part.method == "fem" and part.group == lat.region:
                fail(f"partitions[{p}].group", f"{shown(part.group)} is the lattice region: its cells "
                     "only give the DEM region's shape")

    # The FE side's stability: its external particles held, its step below
    # TRANSITION_OMEGA_H[band_motion] / omega_max; sub-cycled, a damping ratio
    # >= TRANSITION_XI at the DEM's omega_max (docs/transition.md).
    @classmethod
    def holds_externals(cls, scene, spec) -> bool:
        return spec.method == "fem"

    @classmethod
    def step_limit(cls, scene, spec, limit: float) -> tuple[float, str]:
        if spec.method != "fem":
            return limit, ""
        limit = min(limit, TRANSITION_OMEGA_H[scene.coupling.band_motion])
        return limit, f"; the transition scheme keeps omega_max * fdt < {limit:.3g}"

    @classmethod
    def built_problems(cls, scene, freqs) -> list[str]:
        """A sub-cycled coupling whose stiffness-proportional damping gives less
        than TRANSITION_XI at the dem partition's omega_max."""
        if scene.system_ratio == 1:
            return []
        need, fr = stability.damping_need(scene, freqs)
        if scene.damping.beta >= need * (1 - 1e-12):
            return []
        return [f"damping.beta: {scene.damping.beta:g} s: the transition scheme sub-cycles (FE step "
                f"{scene.system_ratio} x the DE step) and needs damping.beta >= {need:.3g} s, a "
                f"damping ratio >= {TRANSITION_XI:g} at the DEM's highest frequency "
                f"{fr.omega_max:.4g} rad/s; without it the sub-cycled coupling is weakly unstable "
                "(docs/transition.md)"]

    @classmethod
    def refusal_context(cls, scene, freqs) -> str | None:
        """Both sides' critical steps and the largest FE step ratio the guard
        accepts at time.dt (stability.largest_stable_ratio: the same rules that refuse)."""
        if not freqs:
            return None
        dt, = stability.seconds(scene.time.dt)
        out = []
        ratio, blocker = stability.largest_stable_ratio(scene, freqs)
        for p in scene.partitions:
            crit = freqs.get(p.name, (None, None))[1]
            if crit is None:
                continue
            text = f"{p.name} critical step {stability.seconds(crit)[0]} s"
            if p.method == "fem" and ratio:
                text += f" (largest stable ratio {ratio} at time.dt {dt} s)"
            elif p.method == "fem" and ratio == 0:
                text += f" (no stable ratio at time.dt {dt} s" + (
                    f": partition '{blocker}' is unstable at it)" if blocker else ")")
            out.append(text)
        return "transition zone: " + ", ".join(out)

    # ------------------------------------------------------------- stepping
    @staticmethod
    def treatments(scene) -> list[str]:
        return ["prescribed" if p.method == "fem" else "taylor" for p in scene.partitions]

    @staticmethod
    def _solved_last(scene) -> int:
        return next(k for k, p in enumerate(scene.partitions) if p.method == "fem")

    def __init__(self, scene, built, comm):
        super().__init__(scene, built, comm)
        motion = scene.coupling.band_motion
        ext, fe = self.explicit, self.implicit
        self._band = None
        self._linear = None
        if ext is not None and motion == "linear":
            n = ext.n_own
            self._linear = (ext.V[n:], ext.A[n:], 0.5 * scene.system_dt)
        elif ext is not None and motion != "predictor":
            n = ext.n_own
            self._band = ext.A[n:] if motion == "velocity" else ext.state[1:, n:]
        if fe is not None:
            # the particles' exchanged state at t_n+1 is what the FE forces use
            # (explicit Newmark evaluates its residual at the predicted u~, v~)
            n = fe.n_own
            self._particles = ((fe.U[n:], fe.work_array("ut")[n:]),
                               (fe.V[n:], fe.work_array("vt")[n:]))

    def describe(self) -> str:
        return ("transition-zone scheme (Zhang et al. 2009): dem sub-steps over the band's motion, then the "
                "explicit FE step with the particles' forces on its band nodes")

    def _finish(self, t1):
        for exchanged, predicted in self._particles:
            np.copyto(predicted, exchanged)
        super()._finish(t1)

    def _received(self):
        if self._band is not None:
            self._band[...] = 0.0          # velocity: a = 0; hold: v = a = 0 until the next sync
        elif self._linear is not None:     # linear: v = (u_n+1 - u_n) / fdt = v + fdt/2 a, a = 0
            v, a, half = self._linear
            v += half * a
            a[...] = 0.0

    def synchronise(self):
        super().synchronise()
        self._received()
