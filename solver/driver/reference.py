"""Exact (modal) solution of an undamped network M u'' + K u = f(t).

Mass-normalised modes phi (phi^T M phi = I, phi^T K phi = diag(omega^2))
decouple the system into unit oscillators q'' + omega^2 q = phi^T f(t), whose
responses to sine, half-sine and piecewise-linear loads are closed forms.
Rigid-body modes (omega = 0) are handled.  Times are processed in chunks so a
long history of a large model stays small in memory.
"""
from __future__ import annotations

import math

import numpy as np

from solver.model.arrays import dof_masses
from solver.model.loads import HalfSine, Rectangular, Sine, Tabulated

ZERO = 1e-9        # omega below this (relative to the largest) is a rigid mode


def free(q0, qd0, w, t):
    """q, q' of q'' + w^2 q = 0 from (q0, qd0); t: [nt], w/q0/qd0: [nm]."""
    wt = np.outer(t, w)
    c, s = np.cos(wt), np.sin(wt)
    rigid = w == 0
    wsafe = np.where(rigid, 1.0, w)
    q = q0 * c + np.where(rigid, qd0 * t[:, None], qd0 / wsafe * s)
    qd = np.where(rigid, qd0, -q0 * w * s + qd0 * c)
    return q, qd


def free_damped(q0, qd0, w, c, t):
    """q, q' of q'' + c q' + w^2 q = 0 (underdamped, or w = 0) from (q0, qd0)."""
    T = t[:, None]
    rigid = w == 0
    ws = np.where(rigid, 1.0, w)
    xw = 0.5 * c                                     # xi * omega
    wd = np.sqrt(np.maximum(ws ** 2 - xw ** 2, 1e-300))
    e = np.exp(-xw * T)
    cos, sin = np.cos(wd * T), np.sin(wd * T)
    q = e * (q0 * cos + (qd0 + xw * q0) / wd * sin)
    qd = e * (qd0 * cos - (ws ** 2 * q0 + xw * qd0) / wd * sin)
    cs = np.where(c > 0, c, 1.0)
    q_r = np.where(c > 0, q0 + qd0 * (1 - np.exp(-cs * T)) / cs, q0 + qd0 * T)
    qd_r = np.where(c > 0, qd0 * np.exp(-cs * T), qd0 + 0 * T)
    return np.where(rigid, q_r, q), np.where(rigid, qd_r, qd)


def sine_response(A, W, w, t):
    """q, q' of q'' + w^2 q = A sin(W t), zero initial state."""
    t = t[:, None]
    rigid = w == 0
    resonant = (~rigid) & (np.abs(w - W) <= 1e-8 * np.maximum(w, W))
    general = ~(rigid | resonant)
    ws = np.where(rigid | resonant, 2.0, w)          # safe values for the masked branches
    d = np.where(general, ws ** 2 - W ** 2, 1.0)
    q = np.where(general, A / d * (np.sin(W * t) - W / ws * np.sin(ws * t)), 0.0)
    qd = np.where(general, A * W / d * (np.cos(W * t) - np.cos(ws * t)), 0.0)
    wr = np.where(resonant, w, 1.0)
    q = q + np.where(resonant, A / (2 * wr ** 2) * (np.sin(wr * t) - wr * t * np.cos(wr * t)), 0.0)
    qd = qd + np.where(resonant, A * t * np.sin(wr * t) / 2, 0.0)
    q = q + np.where(rigid, A * (t / W - np.sin(W * t) / W ** 2), 0.0)
    qd = qd + np.where(rigid, A * (1 - np.cos(W * t)) / W, 0.0)
    return q, qd


def half_sine_response(g: HalfSine, w, t):
    W = math.pi / g.duration
    q = np.zeros((t.size, w.size))
    qd = np.zeros_like(q)
    tau = t - g.start
    on = (tau >= 0) & (tau <= g.duration)
    if on.any():
        q[on], qd[on] = sine_response(g.amplitude, W, w, tau[on])
    after = tau > g.duration
    if after.any():
        qT, qdT = sine_response(g.amplitude, W, w, np.array([g.duration]))
        q[after], qd[after] = free(qT[0], qdT[0], w, tau[after] - g.duration)
    return q, qd


def rectangular_response(g: Rectangular, w, t):
    q = np.zeros((t.size, w.size))
    qd = np.zeros_like(q)
    tau = t - g.start
    on = (tau >= 0) & (tau < g.duration)
    zero = np.zeros(w.size)
    if on.any():
        q[on], qd[on] = ramp_response(zero, zero, g.amplitude, 0.0, w, tau[on])
    after = tau >= g.duration
    if after.any():
        qT, qdT = ramp_response(zero, zero, g.amplitude, 0.0, w, np.array([g.duration]))
        q[after], qd[after] = free(qT[0], qdT[0], w, tau[after] - g.duration)
    return q, qd


def ramp_response(q0, qd0, c, s, w, tau):
    """q, q' from (q0, qd0) under c + s*tau over local time tau."""
    q, qd = free(q0, qd0, w, tau)
    T = tau[:, None]
    rigid = w == 0
    ws = np.where(rigid, 1.0, w)
    wt = ws * T
    q = q + np.where(rigid, c * T ** 2 / 2 + s * T ** 3 / 6,
                     c / ws ** 2 * (1 - np.cos(wt)) + s / ws ** 2 * (T - np.sin(wt) / ws))
    qd = qd + np.where(rigid, c * T + s * T ** 2 / 2,
                       c / ws * np.sin(wt) + s / ws ** 2 * (1 - np.cos(wt)))
    return q, qd


def tabulated_response(g: Tabulated, w, t):
    tk = np.asarray(g.times, dtype=float)
    fk = np.asarray(g.forces, dtype=float)
    cuts = np.concatenate([[0.0], tk[tk > 0], [np.inf]])
    q = np.zeros((t.size, w.size))
    qd = np.zeros_like(q)
    qa, qda = np.zeros(w.size), np.zeros(w.size)
    for a, b in zip(cuts[:-1], cuts[1:]):
        fa = float(np.interp(a, tk, fk))
        slope = 0.0 if not np.isfinite(b) else (float(np.interp(b, tk, fk)) - fa) / (b - a)
        sel = (t >= a) & (t < b)
        if sel.any():
            q[sel], qd[sel] = ramp_response(qa, qda, fa, slope, w, t[sel] - a)
        if np.isfinite(b):
            qe, qde = ramp_response(qa, qda, fa, slope, w, np.array([b - a]))
            qa, qda = qe[0], qde[0]
    return q, qd


def forced_response(g, w, t):
    if isinstance(g, Sine):
        return sine_response(g.amplitude, g.omega, w, t)
    if isinstance(g, HalfSine):
        return half_sine_response(g, w, t)
    if isinstance(g, Tabulated):
        return tabulated_response(g, w, t)
    if isinstance(g, Rectangular):
        return rectangular_response(g, w, t)
    raise TypeError(f"no exact response for {type(g).__name__}")


def modes(model):
    """(omega [nm], phi [n_dofs, nm]) mass-normalised."""
    m = dof_masses(model, np.arange(model.n_nodes))
    s = 1.0 / np.sqrt(m)
    lam, psi = np.linalg.eigh(model.full_stiffness() * s[:, None] * s[None, :])
    lam = np.where(lam < ZERO * max(lam.max(), 1.0), 0.0, lam)
    return np.sqrt(lam), psi * s[:, None]


def modal(model, dofs, t, chunk=4096, damping=None):
    """Exact displacement and velocity at ``dofs`` for times ``t``: [nt, len(dofs)].
    With Rayleigh ``damping`` (C = alpha M + beta K, modal c = alpha + beta w^2):
    free vibration only, every mode underdamped."""
    t = np.asarray(t, dtype=float)
    dofs = np.asarray(dofs, dtype=np.int64)
    w, phi = modes(model)
    damped = damping is not None and damping.active
    c = damping.alpha + damping.beta * w ** 2 if damped else np.zeros_like(w)
    if damped and (model.loads or np.any((w > 0) & (0.5 * c >= w))):
        raise ValueError("the damped modal reference covers underdamped free vibration only")
    m = dof_masses(model, np.arange(model.n_nodes))
    q0, qd0 = phi.T @ (m * model.u0), phi.T @ (m * model.v0)
    u = np.zeros((t.size, dofs.size))
    v = np.zeros_like(u)
    for a in range(0, t.size, chunk):
        tc = t[a:a + chunk]
        q, qd = free_damped(q0, qd0, w, c, tc) if damped else free(q0, qd0, w, tc)
        for load in model.loads:
            fq, fqd = forced_response(load.function, w, tc)
            q += fq * (load.scale * phi[load.dof])
            qd += fqd * (load.scale * phi[load.dof])
        u[a:a + chunk] = q @ phi[dofs].T
        v[a:a + chunk] = qd @ phi[dofs].T
    return u, v
