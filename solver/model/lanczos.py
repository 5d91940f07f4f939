"""An upper estimate of the largest eigenvalue of a symmetric PSD operator, on any rank count.

:func:`largest` runs ``k`` steps of the three-term Lanczos recurrence on this
rank's rows of A (``apply``: local numpy rows in, local rows out; the dot
products are summed over ``comm``) and returns the largest Ritz value theta
of the tridiagonal T_k.  theta is a Rayleigh quotient of A, so theta <=
lambda_max.  How far below it can be is bounded without any knowledge of the
spectrum (no gap) by Kuczynski and Wozniakowski (SIAM J. Matrix Anal. Appl.
13, 1992, Thm 3.2): for a start vector uniformly distributed on the sphere,

    P[(lambda_max - theta) / lambda_max >= eps] <= 1.648 sqrt(n) exp(-sqrt(eps) (2k - 1)),

n the dimension.  :func:`steps` is the smallest k that brings this below
``failure`` for a given ``eps``, and ``theta / (1 - eps)`` is then above
lambda_max but for that probability.  The bound is the worst case over all
spectra: on meshes theta is within 1e-5 of lambda_max long before that
(docs/benchmarks/bench_critical_step.md), so the estimate is about ``eps`` above the
true value.  Residual tests (||A y - theta y|| small) are not used: on a mesh
with a dense top of the spectrum the residual is small while theta still
sits on a lower eigenvalue (a 70^3 Laplacian: theta 2.4e-5 low at a
residual of 1e-5 theta).

The start vector is a fixed pseudo-random function of every row's model DOF
id (:func:`start`), so the Krylov space does not depend on how the rows are
numbered or spread over ranks: 1 and 2 ranks agree to round-off.  There is
no reorthogonalisation: in floating point the extreme Ritz value converges
at least as in exact arithmetic on a matrix with eigenvalues clustered
within round-off of A's (Greenbaum 1989), and never leaves the spectrum by
more than round-off (Paige 1980); only copies of converged values appear,
which do not matter here.
"""
from __future__ import annotations

import math

import numpy as np

EPS = 2e-3           # lambda_max is estimated as theta / (1 - EPS) ...
FAILURE = 1e-6       # ... after the steps that make it too low less likely than this


def steps(n: int, eps: float, failure: float) -> int:
    """Lanczos steps after which theta < (1 - eps) lambda_max has probability
    below ``failure`` in dimension ``n`` (Kuczynski-Wozniakowski)."""
    if n <= 1:
        return 1
    return max(1, math.ceil((math.log(1.648 * math.sqrt(n) / failure) / math.sqrt(eps) + 1) / 2))


def start(ids: np.ndarray) -> np.ndarray:
    """Pseudo-random values in [-1, 1) from integer ``ids`` (splitmix64): the
    same value for the same model DOF on every rank count."""
    z = np.asarray(ids, dtype=np.uint64) + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) * 2.0 ** -52 - 1.0


def largest(apply, x0: np.ndarray, k: int, comm=None) -> tuple[float, int]:
    """(largest Ritz value after ``k`` Lanczos steps, steps taken) for the
    symmetric PSD operator ``apply`` (returning a new array, which is then
    updated in place) from start rows ``x0`` (this rank's),
    dot products summed over ``comm`` (an mpi4py communicator, or None for
    one process).  Fewer steps when the Krylov space is exhausted (then theta
    is exact); NaN when the operator produced NaN or inf; 0 for a start
    vector of zeros (nothing to step)."""
    from scipy.linalg import eigh_tridiagonal  # lazy: scipy loads only where it is used

    def dot(a, b):
        v = float(np.dot(a, b))
        return comm.allreduce(v) if comm is not None and comm.size > 1 else v

    norm = math.sqrt(dot(x0, x0)) if np.isfinite(dot(x0, x0)) else math.nan
    if not np.isfinite(norm):
        return math.nan, 0
    if norm == 0.0:
        return 0.0, 0
    q = x0 / norm
    q_prev = np.zeros_like(q)
    tmp = np.empty_like(q)                    # the products, in place: no temporaries
    alphas, betas = [], []
    beta = 0.0
    for j in range(1, k + 1):
        w = apply(q)
        alpha = dot(q, w)
        w -= np.multiply(alpha, q, out=tmp)
        w -= np.multiply(beta, q_prev, out=tmp)
        beta = math.sqrt(max(dot(w, w), 0.0)) if np.isfinite(alpha) else math.nan
        if not (np.isfinite(alpha) and np.isfinite(beta)):
            return math.nan, j
        alphas.append(alpha)
        scale = max(scale, abs(alpha)) if j > 1 else abs(alpha)
        if j == k or beta <= 1e-13 * scale:       # done, or an invariant subspace
            break
        betas.append(beta)
        w /= beta
        q_prev, q = q, w
    if len(alphas) == 1:
        return alphas[0], 1
    theta = eigh_tridiagonal(np.array(alphas), np.array(betas[:len(alphas) - 1]),
                             eigvals_only=True, select="i",
                             select_range=(len(alphas) - 1, len(alphas) - 1))[0]
    return float(theta), len(alphas)
