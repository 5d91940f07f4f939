"""Analytic 1D wave in a bar loaded at x = 0 (``reference: {kind: bar_wave}``).

An end traction g(t) sends a wave at c = sqrt(E / rho) with stress g / t
(plane stress: a line load over thickness t) or g (3D: a traction), so the
particle velocity at x is v(t) = g(t - x/c) / (t rho c) and the displacement
its integral.  The solution holds until the reflection from the far end
(x = length) can reach the probe: t < (2 length - x) / c.  Errors are measured
over that window only.
"""
from __future__ import annotations

import numpy as np


def history(scene, t, x):
    """(displacement, velocity, valid mask) at probe abscissa ``x`` and times ``t``."""
    from solver.model.loads import load_function
    ref = scene.reference
    mat = scene.model.material
    c = np.sqrt(mat.E / mat.rho)
    load = scene.loads[ref.load]
    g = load_function(load)
    direction = (load.direction or (1.0,))[0]
    stress = direction / (mat.thickness if mat.kind == "plane_stress" else 1.0)
    tau = np.asarray(t) - x / c
    v = np.where(tau >= 0, g.values(np.maximum(tau, 0.0)), 0.0) * stress / (mat.rho * c)
    dt = np.diff(t, prepend=t[0])
    u = np.cumsum(0.5 * (v + np.concatenate([[0.0], v[:-1]])) * dt)   # trapezoidal integral
    valid = np.asarray(t) < (2 * ref.length - x) / c
    return u, v, valid
