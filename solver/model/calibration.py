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
  eps_xx (beams: the strain of the bond's most stretched fibre, axial plus
  bending sqrt(psi)/2 max|4 phi_i + 2 phi_j|, the strain their breakage
  tests).  A square lattice's bonds along the load carry the applied strain
  (1); a random packing's most stretched bond carries more, so under
  uniaxial tension its first bond breaks at break_strain / concentration;
- and ``lateral``: minus the most compressed bond's strain over eps_xx
  (beams: the largest bending minus axial strain), which (the test being
  linear) is the most stretched bond's (fibre's) strain per unit uniaxial
  compression (an affine network's would be nu).

A calibration takes the mean of SAMPLES[dim] such samples (:func:`sampled`;
four in 2D, where one sample's E scatters by 1.7 % from seed to seed; one in
3D, where a test takes 3 s; 3D beams, whose E scatters by 2-4 %, the mean of
BEAM_SAMPLES at the psi found on one).

The same test calibrates beam bonds between rotating particles
(:func:`calibrate_beams`, ``model.lattice.bond: beam``): their transverse stiffness
psi x the axial one lowers nu from the central-bond value to 0 near psi = 1
(2D and 3D), so Brent's method on the measured nu finds psi, then kappa sets E.

A scene's bonds get kappa = E / E_measured (plane strain: E / (1 - nu^2)).
Central bonds give the packing its own nu (an isotropic central-force network
obeys the Cauchy relation lambda = mu in the affine limit, nu = 1/3 in 2D
and 1/4 in 3D; relaxation moves it a little: 0.33-0.34 and 0.24 measured);
``calibrate`` refuses a material whose
nu is further than NU_TOLERANCE from it.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from solver.model import dilatation, packing

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
    lateral: float        # minus the most compressed bond's strain / the applied strain:
    #                       the most stretched bond's per unit uniaxial compression
    samples: int = 1      # how many samples these are the mean of


def _solve(rows, cols, vals, n, fixed, value, rotating: bool = False):
    """Displacements of K u = 0 with u[fixed] = value: one sparse LU solve of
    the free rows (SciPy's SuperLU, COLAMD ordering); ``rotating``: 3D beams'
    (u, theta) per particle, by conjugate gradients with
    :func:`_beam_preconditioner` (its own translations' incomplete LU: 10 x
    faster than an LU of the whole).  Not PETSc: the calibration runs while rank 0 reads
    the scene, before PETSc is started (its initialisation is collective over
    all ranks)."""
    from scipy.sparse.linalg import spsolve  # lazy: scipy loads only for a random packing
    A, rhs, free = _free(rows, cols, vals, n, fixed, value)
    u = np.zeros(n)
    u[fixed] = value
    u[free] = (_solve_pcg(A, rhs, _beam_preconditioner(A, free), rtol=1e-9) if rotating else
               spsolve(A.tocsc(), rhs))
    return u


def bond_blocks(x, i, j, k, shear: float = 0.0) -> np.ndarray:
    """Stiffness blocks [n_bonds, 2 nd, 2 nd] of bonds (i, j) at rest, DOFs
    (particle i's, then j's): central springs k n n^T (nd = dim), or with
    ``shear`` psi > 0, beam bonds (:func:`beams_at_rest`) of axial stiffness k
    and Euler-Bernoulli bending k_b = psi k L^2 / 12 (transverse stiffness
    12 k_b / L^2 = psi k)."""
    d = x[j] - x[i]
    if not shear:
        e1 = d / np.linalg.norm(d, axis=1)[:, None]
        g = np.concatenate([-e1, e1], axis=1)
        return k[:, None, None] * g[:, :, None] * g[:, None, :]
    return beams_at_rest(d, k, shear * k * np.sum(d * d, axis=1) / 12.0)


ROTATING_DOFS = {2: 3, 3: 6}   # a rotating particle's DOFs: (u_x, u_y, theta), (u, theta)


def beams_at_rest(d, k_n, k_b) -> np.ndarray:
    """The stiffness blocks at rest of beam bonds of rest separations ``d``:
    :func:`beam_blocks` in 2D, :func:`beam_blocks3d` (torsion
    :func:`torsion`) in 3D."""
    if d.shape[1] == 3:
        return beam_blocks3d(d, k_n, k_b, torsion(k_b))
    return beam_blocks(d, k_n, k_b)


def torsion(k_b):
    """The torsional stiffness k_t = G_b J / L of 3D beam bonds of bending
    stiffness k_b = E_b I / L: a circular section (J = 2 I) of a bond material
    with nu_b = 0 (G_b = E_b / 2), so k_t = k_b."""
    return np.asarray(k_b, float)


def beam_blocks(d, k_n, k_b) -> np.ndarray:
    """[n_bonds, 6, 6]: the stiffness at rest of 2D beam bonds of rest
    separations ``d`` [n, 2] (:mod:`solver.partitions.beam_bond` linearised,
    Euler-Bernoulli), axial stiffness k_n and bending k_b = E I / L, on the DOFs
    (u_x, u_y, theta) of particle i, then j."""
    L = np.linalg.norm(d, axis=1)
    e1 = d / L[:, None]
    e2 = np.stack([-e1[:, 1], e1[:, 0]], axis=1)
    zero, one = np.zeros(len(L)), np.ones(len(L))
    g = np.stack([-e1[:, 0], -e1[:, 1], zero, e1[:, 0], e1[:, 1], zero], axis=1)
    # phi_i = theta_i - beta, phi_j = theta_j - beta, beta = e2 . (u_j - u_i) / L
    b = np.stack([e2[:, 0] / L, e2[:, 1] / L, zero, -e2[:, 0] / L, -e2[:, 1] / L, zero], axis=1)
    B = np.stack([b + np.stack([zero, zero, one, zero, zero, zero], 1),
                  b + np.stack([zero, zero, zero, zero, zero, one], 1)], axis=1)   # [nb, 2, 6]
    Kb = np.asarray(k_b, float)[:, None, None] * np.array([[4.0, 2.0], [2.0, 4.0]])
    return (np.asarray(k_n, float)[:, None, None] * g[:, :, None] * g[:, None, :] +
            np.einsum("bpr,bpq,bqs->brs", B, Kb, B))


def beam_blocks3d(d, k_n, k_b, k_t) -> np.ndarray:
    """[n_bonds, 12, 12]: the stiffness at rest of 3D beam bonds of rest
    separations ``d`` [n, 3] (:mod:`solver.partitions.beam_bond3d`
    linearised, Euler-Bernoulli), axial k_n, bending k_b and torsion k_t, on
    the DOFs (u, theta) of particle i, then j: the tilts g_e = [e0]x ((u_j -
    u_i) / L + [e0]x theta_e), the twist e0 . (theta_j - theta_i)."""
    n = len(d)
    L = np.linalg.norm(d, axis=1)
    e0 = d / L[:, None]
    z = np.zeros((n, 3))
    a = np.concatenate([-e0, z, e0, z], axis=1)                      # the stretch
    t = np.concatenate([z, -e0, z, e0], axis=1)                      # the twist
    E = np.zeros((n, 3, 3))
    E[:, 0, 1], E[:, 0, 2], E[:, 1, 2] = -e0[:, 2], e0[:, 1], -e0[:, 0]
    E -= np.transpose(E, (0, 2, 1))                                  # [e0]x
    EE = E @ E
    Z = np.zeros((n, 3, 3))
    G_i = np.concatenate([-E / L[:, None, None], EE, E / L[:, None, None], Z], axis=2)
    G_j = np.concatenate([-E / L[:, None, None], Z, E / L[:, None, None], EE], axis=2)
    k_b = np.asarray(k_b, float)[:, None, None]
    bend = (4.0 * k_b * (np.einsum("bri,brj->bij", G_i, G_i) +
                         np.einsum("bri,brj->bij", G_j, G_j)) +
            2.0 * k_b * (np.einsum("bri,brj->bij", G_i, G_j) +
                         np.einsum("bri,brj->bij", G_j, G_i)))
    return (np.asarray(k_n, float)[:, None, None] * a[:, :, None] * a[:, None, :] + bend +
            np.asarray(k_t, float)[:, None, None] * t[:, :, None] * t[:, None, :])


def _coo(i, j, blocks):
    """COO triplets of the bond blocks on nd DOFs per particle."""
    nd = blocks.shape[1] // 2
    dofs = np.concatenate([i[:, None] * nd + np.arange(nd), j[:, None] * nd + np.arange(nd)],
                          axis=1)
    rows = np.repeat(dofs, 2 * nd, axis=1).ravel()
    cols = np.tile(dofs, (1, 2 * nd)).ravel()
    return rows, cols, blocks.ravel(), dofs


@lru_cache(maxsize=8)
def _packing(dim: int, spread: float, gap: float, seed: int):
    """The sample's packing at unit spacing: (x, r, i, j, k) its particles,
    radii, bonds and their stiffness at kappa = 1 (0.75 s in 3D: made once
    for the tests of a calibration)."""
    x, r = packing.poisson_disc(np.zeros(dim), np.full(dim, SIDE[dim]), 0.5, spread, seed)
    i, j = packing.neighbour_pairs(x, r, gap)
    return x, r, i, j, packing.bond_stiffness(x, r, i, j, 1.0, 1.0)


def _system(dim: int, spread: float, gap: float, seed: int, shear: float = 0.0):
    """The sample's packing, its bonds' stiffness (COO, a weak tie to the ground
    included) and the grips: (x, r, i, j, blocks, dofs, (rows, cols, vals, n),
    fixed, value)."""
    side = SIDE[dim]
    x, r, i, j, k = _packing(dim, spread, gap, seed)
    blocks = bond_blocks(x, i, j, k, shear)
    nd = blocks.shape[1] // 2
    rows, cols, vals, dofs = _coo(i, j, blocks)
    n = x.shape[0] * nd
    # a weak tie to the ground (1e-9 of the mean bond) keeps floppy particles
    # (too few bonds to hold them, rattlers) from making K singular
    rows, cols = np.concatenate([rows, np.arange(n)]), np.concatenate([cols, np.arange(n)])
    vals = np.concatenate([vals, np.full(n, 1e-9 * k.mean())])
    eps = 1e-3
    left = np.flatnonzero(x[:, 0] < GRIP)
    right = np.flatnonzero(x[:, 0] > side - GRIP)
    mid = left[np.argsort(np.abs(x[left, 1:] - side / 2).sum(axis=1))]
    fixed = [left * nd, right * nd, [mid[0] * nd + c for c in range(1, dim)]]
    value = [np.zeros(left.size), np.full(right.size, eps * side), np.zeros(dim - 1)]
    if dim == 3:                                   # rotation about x
        other = left[np.argmax(np.abs(x[left, 1] - x[mid[0], 1]))]
        fixed.append([other * nd + 2])
        value.append([0.0])
    fixed = np.concatenate([np.asarray(f, np.int64) for f in fixed])
    value = np.concatenate([np.asarray(v, float) for v in value])
    return x, r, i, j, blocks, dofs, (rows, cols, vals, n), fixed, value


def _free(rows, cols, vals, n, fixed, value):
    """(A, rhs, free DOFs) of K u = 0 with u[fixed] = value, on the free rows."""
    from scipy.sparse import coo_matrix  # lazy: scipy loads only for a random packing
    K = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    free = np.ones(n, bool)
    free[fixed] = False
    u = np.zeros(n)
    u[fixed] = value
    return K[free][:, free], -(K[free][:, ~free] @ u[~free]), np.flatnonzero(free)


@lru_cache(maxsize=4)
def _bond_factor(dim: int, spread: float, gap: float, seed: int, shear: float = 0.0):
    """SuperLU factor of the free rows of the sample's bond stiffness: central
    (the preconditioner of :func:`measure` with the volumetric term), or
    (:func:`_translations_factor`) of the translations' rows of beams at psi
    = ``shear`` (of 3D beams at any psi, with the rotations' blocks:
    :func:`_beam_preconditioner`)."""
    from scipy.sparse.linalg import splu  # lazy: scipy loads only for a random packing
    *_, system, fixed, value = _system(dim, spread, gap, seed, shear)
    A, _, free = _free(*system, fixed, value)
    return _translations_factor(A, free) if shear else splu(A.tocsc())


def _translations_factor(A, free):
    """An incomplete LU (drop tolerance 1e-2, fill factor 5) of the
    translations' rows of 3D beams' free rows ``A`` (``free``: their DOFs, 6
    per particle): 0.5 s on a 20^3 sample, against 2 s for their LU, and CG
    with it is faster still (160-210 iterations of 3 ms against 45-80 of
    25 ms)."""
    from scipy.sparse.linalg import spilu  # lazy: scipy loads only for a random packing
    moves = np.flatnonzero(free % 6 < 3)
    return spilu(A[moves][:, moves].tocsc(), drop_tol=1e-2, fill_factor=5)


BEAM_REFERENCE = 0.5    # 3D beams' tests are preconditioned by the translations' ILU at this psi


def _beam_preconditioner(A, free, factor=None):
    """M^-1 of 3D beams' free rows ``A`` (``free``: their DOFs, 6 per
    particle; only translations are ever held): block Jacobi, the
    translations' rows by ``factor`` (default: :func:`_translations_factor`
    of A; the sample's at BEAM_REFERENCE serves every psi, the stiffness
    being linear in psi), each particle's three rotations by the inverse of
    their 3 x 3 diagonal block.  CG takes 160-210 iterations at psi 0.02-2
    (0.5-0.7 s, against 15 s for one LU of the whole system)."""
    from scipy.sparse.linalg import LinearOperator  # lazy: as above
    turns = np.flatnonzero(free % 6 >= 3)
    moves = np.flatnonzero(free % 6 < 3)
    if factor is None:
        factor = _translations_factor(A, free)
    a, b = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
    first = turns[::3]
    D = np.asarray(A[(first[:, None, None] + a).ravel(), (first[:, None, None] + b).ravel()])
    inv = np.linalg.inv(D.reshape(-1, 3, 3))

    def apply(v):
        out = np.empty_like(v)
        out[moves] = factor.solve(v[moves])
        out[turns] = np.einsum("pij,pj->pi", inv, v[turns].reshape(-1, 3)).ravel()
        return out
    return LinearOperator(A.shape, apply)


def _solve_pcg(A, rhs, M, rtol=1e-12):
    """Conjugate gradients on ``A`` u = ``rhs`` preconditioned by ``M``, to ``rtol``.
    The volumetric term stiffens only the dilatational modes: the central
    bonds' LU takes 15 iterations at eta = 1, 100-150 at eta = 100-1000 (one
    LU of the wider matrix took 3 x longer than a whole solve at small eta)."""
    from scipy.sparse.linalg import cg  # lazy: scipy loads only for a random packing
    u, info = cg(A, rhs, x0=M @ rhs, rtol=rtol, maxiter=1000, M=M)
    if info:
        raise ValueError(f"the calibration's solve did not converge in {info} iterations")
    return u


@lru_cache(maxsize=64)
def measure(dim: int, spread: float, gap: float, seed: int, shear: float = 0.0,
            bulk: float = 0.0) -> Measured:
    """E and nu of a packing with these settings at kappa = 1 (see the module);
    ``shear`` psi > 0: beam bonds of transverse stiffness psi k (rotations);
    ``bulk`` eta > 0: the volumetric term c_p = eta V_p n_p / n_full
    (:mod:`solver.model.dilatation`)."""
    x, r, i, j, blocks, dofs, (rows, cols, vals, n), fixed, value = _system(
        dim, spread, gap, seed, shear)
    if bulk:
        G = dilatation.gradient(x, i, j)
        c = bulk * dilatation.weights(r, i, j, dim)
        Kv = (G.T @ G.multiply(c[:, None])).tocoo()
        rows, cols = np.concatenate([rows, Kv.row]), np.concatenate([cols, Kv.col])
        vals = np.concatenate([vals, Kv.data])
    if bulk or (shear and dim == 3):
        from scipy.sparse.linalg import LinearOperator  # lazy: as _solve's
        A, rhs, free = _free(rows, cols, vals, n, fixed, value)
        M = (LinearOperator(A.shape, _bond_factor(dim, spread, gap, seed).solve) if bulk else
             _beam_preconditioner(A, free, _bond_factor(dim, spread, gap, seed, BEAM_REFERENCE)))
        u = np.zeros(n)
        u[fixed] = value
        u[free] = _solve_pcg(A, rhs, M, rtol=1e-12 if bulk else 1e-9)
    else:
        u = _solve(rows, cols, vals, n, fixed, value)
    with np.errstate(invalid="ignore", divide="ignore"):
        return _measured(x, i, j, blocks, dofs, u, SIDE[dim], shear,
                         c * (G @ u) * dim / dilatation.counts(i, j, len(x)) if bulk else None)


def _measured(x, i, j, blocks, dofs, u, side, shear=0.0, P=None):
    """E, nu and the strain concentration of the solved sample (see the module);
    ``P``: the volumetric term's P_p = c_p theta_p dim / n_p, whose bond
    tensions (P_i + P_j) / L join the virial."""
    dim = x.shape[1]
    nd = blocks.shape[1] // 2
    ut = u.reshape(-1, nd)[:, :dim]
    inner = np.all((x > WINDOW) & (x < side - WINDOW), axis=1)
    design = np.hstack([np.ones((inner.sum(), 1)), x[inner]])
    grad = np.linalg.lstsq(design, ut[inner], rcond=None)[0][1:].T     # du_a / dx_b
    mids = 0.5 * (x[i] + x[j])
    inside = np.all((mids > WINDOW) & (mids < side - WINDOW), axis=1)
    d = x[j[inside]] - x[i[inside]]
    L = np.linalg.norm(d, axis=1)
    # the force each bond needs at its end j (tension: along d), times d: the virial
    f_j = np.einsum("brs,bs->br", blocks[inside], u[dofs[inside]])[:, nd:nd + dim]
    volume = (side - 2 * WINDOW) ** dim
    if P is not None:
        f_j[:, 0] += (P[i[inside]] + P[j[inside]]) / L * d[:, 0] / L
    sxx = np.sum(f_j[:, 0] * d[:, 0]) / volume
    du = ut[j[inside]] - ut[i[inside]]
    axial = np.einsum("ba,ba->b", du, d) / L ** 2
    bend = np.zeros_like(axial)
    if shear and dim == 2:       # beams: the outer fibre's bending strain (BeamBonds.failure)
        theta = u.reshape(-1, nd)[:, dim]
        beta = (d[:, 0] * du[:, 1] - d[:, 1] * du[:, 0]) / L ** 2
        phi_i, phi_j = theta[i[inside]] - beta, theta[j[inside]] - beta
        bend = 0.5 * np.sqrt(shear) * np.maximum(np.abs(4 * phi_i + 2 * phi_j),
                                                 np.abs(2 * phi_i + 4 * phi_j))
    elif shear:                  # 3D: a circular section's (BeamBonds3D.failure), the tilts
        theta = u.reshape(-1, nd)[:, dim:]        # g_e = e0 x (du / L + e0 x theta_e)
        e0 = d / L[:, None]
        g_i, g_j = (np.cross(e0, du / L[:, None] + np.cross(e0, theta[e[inside]]))
                    for e in (i, j))
        bend = np.sqrt(shear / 3.0) * np.maximum(np.linalg.norm(4 * g_i + 2 * g_j, axis=1),
                                                 np.linalg.norm(2 * g_i + 4 * g_j, axis=1))
    exx = grad[0, 0]
    lateral = np.mean([grad[c, c] for c in range(1, dim)])
    return Measured(sxx / exx, -lateral / exx, int(x.shape[0]), int(i.size),
                    2.0 * i.size / x.shape[0], float((axial + bend).max() / exx),
                    float((bend - axial).max() / exx))


SAMPLES = {2: 4, 3: 1}     # samples a calibration averages over (3D: one, 3 s each)
BEAM_SAMPLES = 4           # 3D beams: their psi found on one, E and nu the mean of this many
SAMPLE_SEED = 7919         # sample s of a scene's seed is packed with seed + s x this


@lru_cache(maxsize=64)
def sampled(dim: int, spread: float, gap: float, seed: int, shear: float = 0.0,
            bulk: float = 0.0, samples: int = 0) -> Measured:
    """The packing's constants as :func:`measure` gives them, averaged over
    ``samples`` (default SAMPLES[dim]) samples (seeds seed + s SAMPLE_SEED):
    one 60 x 60 sample's E scatters by 1.7 % from seed to seed (2D beams,
    seeds 0-5: 0.871 to 0.901), and the mean of four halves that; one 20^3
    sample of 3D beams' by 2-4 %; ``particles`` and ``bonds`` are the
    samples' totals."""
    got = [measure(dim, float(spread), float(gap), int(seed) + s * SAMPLE_SEED, float(shear),
                   float(bulk)) for s in range(samples or SAMPLES[dim])]
    if len(got) == 1:
        return got[0]
    mean = {f: float(np.mean([getattr(m, f) for m in got]))
            for f in ("E", "nu", "coordination", "concentration", "lateral")}
    return Measured(particles=sum(m.particles for m in got), bonds=sum(m.bonds for m in got),
                    samples=len(got), **mean)


def tests(m: Measured) -> str:
    """What the calibration measured, for the log: "uniaxial tests of 4 samples
    (9187 particles)"."""
    return (f"uniaxial tests of {m.samples} samples ({m.particles} particles)" if m.samples > 1
            else f"a uniaxial test of {m.particles} particles")


def calibrate(E: float, nu: float, kind: str, spread: float, gap: float,
              seed: int, check: bool = True) -> tuple[float, Measured]:
    """(kappa, the packing measured at kappa = 1): the bond factor that gives the packing
    Young's modulus E; ValueError when nu is not what it represents (``check``
    False: not checked, only a floppy packing refused)."""
    dim = 3 if kind == "solid" else 2
    m = sampled(dim, float(spread), float(gap), int(seed))
    if not np.isfinite(m.E) or m.E < 0.05:
        raise Floppy(f"{gap:g} leaves the packing floppy: {m.coordination:.2f} bonds per "
                     f"particle, E {m.E:.2g} x the bonds' (a rigid {dim}D network of central "
                     f"bonds needs more than {2 * dim}); give a larger gap (1 gives about "
                     f"{6 if dim == 2 else 13})")
    if kind == "plane_strain":                    # in-plane constants of plane strain
        target, represents = E / (1.0 - nu ** 2), m.nu / (1.0 + m.nu)
    else:
        target, represents = E, m.nu
    if check and abs(nu - represents) > NU_TOLERANCE:
        raise ValueError(f"a random packing of central bonds (radius_spread {spread:g}, gap "
                         f"{gap:g}) represents nu = {represents:.3g} in {kind} (measured on a "
                         f"{tests(m)}); the material has nu = "
                         f"{nu:g} (allowed within {NU_TOLERANCE}; {_lower(nu, represents)})")
    return target / E / m.E, m


def _lower(nu: float, represents: float) -> str:
    """What gives a nu the central bonds do not represent."""
    if nu > represents:
        return "a larger nu takes the volumetric term (solver.model.dilatation)"
    return "a smaller one needs beam bonds: model.lattice.bond: beam"


SHEAR_RANGE = (0.0, 2.0)      # psi searched by calibrate_beams
BEAM_NU_STEP = 2e-5           # 3D beams' psi search stops this close to nu


def _falling_root(nu_at, goal: float, top: float, tol: float):
    """(psi, None) with |nu_at(psi) - goal| < tol, nu falling with psi from
    ``top`` = nu_at(0) > goal, or (None, nu at SHEAR_RANGE[1]) when that is
    still above ``goal``.  The first guess is the model nu = top (1 - psi) /
    (1 + psi / 5) (within 0.002 of 3D packings' at psi 0.3, 0.02 at 2), the
    second the model refitted through the first test, then secants kept
    inside the bracket found so far (bisecting where one leaves it): 3-4
    tests, against Brent's 6-7 on the whole range."""
    lo, hi = 0.0, None                     # psi above and below the goal so far

    def model(psi, value):                 # the model's psi for the goal, through (psi, value)
        k = (top * (1.0 - psi) / value - 1.0) / psi if psi and value else 0.2
        g = goal / top if top > 0 else 0.0
        return (1.0 - g) / (1.0 + max(k, -0.9) * g)
    tried = []
    psi = model(0.0, 0.0) if top > 0 else SHEAR_RANGE[1]
    for _ in range(60):
        ceiling = SHEAR_RANGE[1] if hi is None else hi
        if not lo < psi < ceiling:
            psi = 0.5 * (lo + hi) if hi is not None else SHEAR_RANGE[1]
        value = nu_at(psi)
        tried.append((psi, value))
        if abs(value - goal) < tol:
            return psi, None
        if value > goal:
            lo = psi
            if psi >= SHEAR_RANGE[1]:
                return None, value
        else:
            hi = psi
        if len(tried) == 1:
            psi = model(psi, value)
        else:
            (p0, v0), (p1, v1) = tried[-2:]
            psi = p1 - (v1 - goal) * (p1 - p0) / (v1 - v0) if v1 != v0 else -1.0
    return min(tried, key=lambda t: abs(t[1] - goal))[0], None       # (the closest tried)


def calibrate_beams(E: float, nu: float, kind: str, spread: float, gap: float,
                    seed: int) -> tuple[float, float, Measured]:
    """(kappa, psi, the packing measured at kappa = 1 and that psi) of beam
    bonds (:func:`bond_blocks`): psi, the bonds' transverse stiffness over
    their axial one, sets nu (the packing's central-bond nu at psi = 0,
    falling through 0 near psi = 1 in 2D and 3D), found by Brent's method on
    the measured nu (to 1e-6 in psi; 3D, where a test takes 1.5-2.5 s: by
    :func:`_falling_root` to BEAM_NU_STEP, on one sample); kappa then sets E,
    measured in 3D as the mean of BEAM_SAMPLES samples at that psi (whose
    mean nu then differs from the one sample's by a few 1e-3).  ValueError for a nu outside the
    range psi in SHEAR_RANGE covers, naming it."""
    from scipy.optimize import brentq  # lazy: scipy loads only for a random packing
    dim = 3 if kind == "solid" else 2
    in_plane = nu / (1.0 - nu) if kind == "plane_strain" else nu
    target = E / (1.0 - nu ** 2) if kind == "plane_strain" else E

    def nu_at(psi):                          # (3D: one sample)
        return sampled(dim, float(spread), float(gap), int(seed), float(psi)).nu

    def plain(v):
        return v / (1.0 + v) if kind == "plane_strain" else v
    try:
        lo = nu_at(SHEAR_RANGE[0])
        if in_plane > lo:                          # (known without a test of beams)
            raise ValueError(f"beam bonds in a random packing (radius_spread {spread:g}, gap "
                             f"{gap:g}) cover nu up to the central bonds' {plain(lo):.3g} in "
                             f"{kind}; the material has nu = {nu:g} (a larger nu takes "
                             "central bonds, bond: central, with the volumetric term)")
        if dim == 2:
            hi = nu_at(SHEAR_RANGE[1])
            psi = brentq(lambda p: nu_at(p) - in_plane, *SHEAR_RANGE, xtol=1e-6,
                         rtol=1e-10) if hi <= in_plane else None
        else:
            psi, hi = _falling_root(nu_at, in_plane, lo, BEAM_NU_STEP)
        if psi is None:
            raise ValueError(f"beam bonds in a random packing (radius_spread {spread:g}, gap "
                             f"{gap:g}) cover nu {plain(max(hi, 0.0)):.3g} to {plain(lo):.3g} "
                             f"in {kind}; the material has nu = {nu:g}")
        m = sampled(dim, float(spread), float(gap), int(seed), float(psi),
                    samples=BEAM_SAMPLES if dim == 3 else 0)
    finally:
        if dim == 3:
            _bond_factor.cache_clear()     # (its LU: 600 MB)
    return target / E / m.E, psi, m


BULK_MIN = 0.005       # a nu this far above the central bonds' takes the volumetric term
BULK_STEP = 1e-4       # calibrate_bulk stops when the measured nu is this close
BULK_LIMIT = 1000.0    # ... and refuses an eta beyond this (nu too near its limit)


def _lame_ratio(nu: float, dim: int) -> float:
    """lambda / mu of an isotropic material of (in-plane) Poisson's ratio nu."""
    return 2.0 * nu / (1.0 - (2.0 if dim == 3 else 1.0) * nu)


def calibrate_bulk(E: float, nu: float, kind: str, spread: float, gap: float,
                   seed: int) -> tuple[float, float, Measured]:
    """(kappa, eta, the packing measured at kappa = 1 and that eta) of central
    bonds with the volumetric term (:mod:`solver.model.dilatation`): eta sets
    nu above the central bonds' own, found by the secant method on lambda/mu
    (nearly linear in eta) to BULK_STEP in nu, one measured test each,
    bisecting where a secant step leaves the bracket found so far; kappa then
    sets E.  ValueError for a nu the term cannot reach (at or beyond the limit:
    1 in plane stress, 1/2 in plane strain and 3D, or not reached at eta =
    BULK_LIMIT)."""
    dim = 3 if kind == "solid" else 2
    in_plane = nu / (1.0 - nu) if kind == "plane_strain" else nu
    target = E / (1.0 - nu ** 2) if kind == "plane_strain" else E
    if not in_plane < (0.5 if dim == 3 else 1.0):
        raise ValueError(f"the volumetric term reaches nu below {0.5 if dim == 3 else 1.0:g} in "
                         f"{kind}; the material has nu = {nu:g}")
    goal = _lame_ratio(in_plane, dim)

    def ratio(eta):
        m = sampled(dim, float(spread), float(gap), int(seed), 0.0, float(eta))
        return _lame_ratio(m.nu, dim) - goal, m

    m0 = sampled(dim, float(spread), float(gap), int(seed))
    f0 = _lame_ratio(m0.nu, dim) - goal
    # first guess: an affine network, lambda grows by eta times the particles' volume fraction
    x, r, i, j, _ = _packing(dim, spread, gap, seed)
    fraction = dilatation.weights(r, i, j, dim).sum() / SIDE[dim] ** dim
    mu = m0.E / (2.0 * (1.0 + m0.nu))
    lo, hi = 0.0, None                 # eta below and above the goal (lambda/mu rises with eta)
    a, fa, b = 0.0, f0, -f0 * mu / fraction
    best = m0.nu
    for _ in range(60):
        if b is None or not lo < b <= (BULK_LIMIT if hi is None else hi):
            b = 0.5 * (lo + hi) if hi is not None else BULK_LIMIT    # the secant left the bracket
        fb, m = ratio(b)
        best = max(best, m.nu)
        if abs(m.nu - in_plane) < BULK_STEP:
            _bond_factor.cache_clear()     # (its LU: 230 MB in 3D)
            return target / E / m.E, b, m
        if fb < 0.0:
            lo = b
            if b >= BULK_LIMIT:            # the packing's own relaxation caps what eta gives
                break
        else:
            hi = b
        a, fa, b = b, fb, (b - fb * (b - a) / (fb - fa) if fb != fa else None)
    _bond_factor.cache_clear()

    def plain(v):
        return v / (1.0 + v) if kind == "plane_strain" else v
    raise ValueError(f"central bonds with the volumetric term reach nu {plain(best):.3g} at most "
                     f"in {kind} (radius_spread {spread:g}, gap {gap:g}; eta up to "
                     f"{BULK_LIMIT:g}); the material has nu = {nu:g}")
