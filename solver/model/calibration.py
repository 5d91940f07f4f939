"""Calibration of a random bonded packing to E and nu by a measured uniaxial test.

A random packing's elastic constants are not those of its bonds' affine
(Voigt) average: particles relax away from a uniform strain, how far depends
on the packing's coordination.  So they are measured, on a sample box packed
with the scene's settings (radius spread, bond gap, seed) at unit spacing,
unit E and unit thickness (the constants scale with E, and are independent
of the spacing):

- the sample (60 x 60 spacings in 2D, 20^3 in 3D) is stretched along x by
  frictionless grips: particles within one spacing of the face x = 0 hold
  u_x = 0, those near x = L get u_x = eps L, the sides are free (one
  particle's lateral motion and, in 3D, a second one's held against rigid
  motion);
- one sparse LU solve of the linear central-bond stiffness gives the
  displacements;
- in a window 4 spacings away from every face the strain is the least-squares
  displacement gradient of its particles, and the stress the bond virial
  sigma = (1/V) sum f (x) L of the bonds whose midpoint is inside it;
- E = sigma_xx / eps_xx, nu = -eps_yy / eps_xx (3D: the mean of y and z);
- the strain concentration: the largest bond strain in the window over
  eps_xx.  A square lattice's bonds along the load carry the applied strain
  (1); a random packing's most stretched bond carries more, so under
  uniaxial tension its first bond breaks at break_strain / concentration.

A scene's bonds get kappa = E / E_measured (plane strain: E / (1 - nu^2)).
Central bonds give the packing its own nu (an isotropic central-force network
obeys the Cauchy relation lambda = mu in the affine limit, nu = 1/3 in 2D
and 1/4 in 3D, relaxation lowers it); ``calibrate`` refuses a material whose
nu is further than NU_TOLERANCE from it.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from solver.model import packing
from solver.model.lattice import bond_triplets

NU_TOLERANCE = 0.03
SIDE = {2: 60.0, 3: 20.0}          # the sample's side [spacings]
WINDOW = 4.0                       # the measuring window's distance from every face [spacings]
GRIP = 1.0                         # particles this close to an end face are gripped [spacings]


class Floppy(ValueError):
    """The sample's network has too few bonds to hold its shape (the gap is too small)."""


@dataclass(frozen=True)
class Measured:
    E: float              # Young's modulus of the packing with kappa = 1 (E = 1, t = 1, a = 1)
    nu: float
    particles: int
    bonds: int
    coordination: float   # mean bonds per particle
    concentration: float  # the largest bond strain in the window / the applied strain


def _solve(rows, cols, vals, n, fixed, value):
    """Displacements of K u = 0 with u[fixed] = value: one sparse LU solve of
    the free rows (SciPy's SuperLU, COLAMD ordering).  Not PETSc: the
    calibration runs while rank 0 reads the scene, before PETSc is started
    (its initialisation is collective over all ranks)."""
    from scipy.sparse import coo_matrix  # lazy: scipy loads only for a random packing
    from scipy.sparse.linalg import spsolve  # lazy: as above
    K = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    free = np.ones(n, bool)
    free[fixed] = False
    u = np.zeros(n)
    u[fixed] = value
    rhs = -(K[free][:, ~free] @ u[~free])
    u[free] = spsolve(K[free][:, free].tocsc(), rhs)
    return u


@lru_cache(maxsize=16)
def measure(dim: int, spread: float, gap: float, seed: int) -> Measured:
    """E and nu of a packing with these settings at kappa = 1 (see the module)."""
    side = SIDE[dim]
    lo, hi = np.zeros(dim), np.full(dim, side)
    x, r = packing.poisson_disc(lo, hi, 0.5, spread, seed)
    i, j = packing.neighbour_pairs(x, r, gap)
    k = packing.bond_stiffness(x, r, i, j, 1.0, 1.0)
    rows, cols, vals = bond_triplets(x, i, j, k, dim)
    n = x.shape[0] * dim
    # a weak tie to the ground (1e-9 of the mean bond) keeps floppy particles
    # (too few bonds to hold them, rattlers) from making K singular
    rows, cols = np.concatenate([rows, np.arange(n)]), np.concatenate([cols, np.arange(n)])
    vals = np.concatenate([vals, np.full(n, 1e-9 * k.mean())])
    eps = 1e-3
    left = np.flatnonzero(x[:, 0] < GRIP)
    right = np.flatnonzero(x[:, 0] > side - GRIP)
    mid = left[np.argsort(np.abs(x[left, 1:] - side / 2).sum(axis=1))]
    fixed = [left * dim, right * dim, [mid[0] * dim + c for c in range(1, dim)]]
    value = [np.zeros(left.size), np.full(right.size, eps * side), np.zeros(dim - 1)]
    if dim == 3:                                   # rotation about x
        other = left[np.argmax(np.abs(x[left, 1] - x[mid[0], 1]))]
        fixed.append([other * dim + 2])
        value.append([0.0])
    fixed = np.concatenate([np.asarray(f, np.int64) for f in fixed])
    value = np.concatenate([np.asarray(v, float) for v in value])
    u = _solve(rows, cols, vals, n, fixed, value).reshape(-1, dim)
    with np.errstate(invalid="ignore", divide="ignore"):
        return _measured(x, r, i, j, k, u, side, dim)


def _measured(x, r, i, j, k, u, side, dim):
    """E, nu and the strain concentration of the solved sample (see the module)."""
    inner = np.all((x > WINDOW) & (x < side - WINDOW), axis=1)
    design = np.hstack([np.ones((inner.sum(), 1)), x[inner]])
    grad = np.linalg.lstsq(design, u[inner], rcond=None)[0][1:].T     # du_a / dx_b
    mids = 0.5 * (x[i] + x[j])
    inside = np.all((mids > WINDOW) & (mids < side - WINDOW), axis=1)
    d = x[j[inside]] - x[i[inside]]
    L = np.linalg.norm(d, axis=1)
    nvec = d / L[:, None]
    stretch = np.einsum("ba,ba->b", u[j[inside]] - u[i[inside]], nvec)
    volume = (side - 2 * WINDOW) ** dim
    sxx = np.sum(k[inside] * stretch * L * nvec[:, 0] ** 2) / volume
    exx = grad[0, 0]
    lateral = np.mean([grad[c, c] for c in range(1, dim)])
    return Measured(sxx / exx, -lateral / exx, int(x.shape[0]), int(i.size),
                    2.0 * i.size / x.shape[0], float((stretch / L).max() / exx))


def calibrate(E: float, nu: float, kind: str, spread: float, gap: float,
              seed: int) -> tuple[float, Measured]:
    """(kappa, the packing measured at kappa = 1): the bond factor that gives the packing
    Young's modulus E; ValueError when nu is not what it represents."""
    dim = 3 if kind == "solid" else 2
    m = measure(dim, float(spread), float(gap), int(seed))
    if not np.isfinite(m.E) or m.E < 0.05:
        raise Floppy(f"{gap:g} leaves the packing floppy: {m.coordination:.2f} bonds per "
                     f"particle, E {m.E:.2g} x the bonds' (a rigid {dim}D network of central "
                     f"bonds needs more than {2 * dim}); give a larger gap (1 gives about "
                     f"{6 if dim == 2 else 13})")
    if kind == "plane_strain":                    # in-plane constants of plane strain
        target, represents = E / (1.0 - nu ** 2), m.nu / (1.0 + m.nu)
    else:
        target, represents = E, m.nu
    if abs(nu - represents) > NU_TOLERANCE:
        raise ValueError(f"a random packing of central bonds (radius_spread {spread:g}, gap "
                         f"{gap:g}) represents nu = {represents:.3g} in {kind} (measured on a "
                         f"uniaxial test of {m.particles} particles); the material has nu = "
                         f"{nu:g} (allowed within {NU_TOLERANCE})")
    return target / E / m.E, m
