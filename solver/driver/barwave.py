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

from solver.model.loads import load_function


def history(scene, t, x):
    """(displacement, velocity, valid mask) at probe abscissa ``x`` and times ``t``."""
    ref = scene.reference
    mat = scene.model.material
    c = np.sqrt(mat.E / mat.rho)
    load = scene.loads[ref.load]
    g = load_function(load)
    direction = (load.direction or (1.0,))[0]
    stress = direction / mat.depth
    tau = np.asarray(t) - x / c
    v = np.where(tau >= 0, g.values(np.maximum(tau, 0.0)), 0.0) * stress / (mat.rho * c)
    dt = np.diff(t, prepend=t[0])
    u = np.cumsum(0.5 * (v + np.concatenate([[0.0], v[:-1]])) * dt)   # trapezoidal integral
    valid = np.asarray(t) < (2 * ref.length - x) / c
    return u, v, valid


def stress(scene, t, x):
    """sigma_xx of the 1D wave at ``x``: -rho c v (compression for a push)."""
    mat = scene.model.material
    _, v, valid = history(scene, t, x)
    return -mat.rho * np.sqrt(mat.E / mat.rho) * v, valid


def arrival(t, s, level=0.5):
    """First time |s| reaches ``level`` of its largest value (linear between samples)."""
    a = np.abs(np.asarray(s))
    if not a.size or a.max() == 0:
        return float("nan")
    thr = level * a.max()
    k = int(np.argmax(a >= thr))
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (thr - a[k - 1]) / (a[k] - a[k - 1]) * (t[k] - t[k - 1]))


def stress_errors(t, s, ref, valid, x, c):
    """Arrival (50 % crossing) error relative to the travel time x/c, and peak
    error relative to the reference peak, over the valid window."""
    t, s, ref = np.asarray(t)[valid], np.asarray(s)[valid], np.asarray(ref)[valid]
    peak_ref = np.abs(ref).max() if ref.size else 0.0
    if peak_ref == 0:
        return float("nan"), float("nan")
    travel = max(x / c, t[1] - t[0])
    return ((arrival(t, s) - arrival(t, ref)) / travel, (np.abs(s).max() - peak_ref) / peak_ref)
