"""Four-node shell element (MITC4, 6 DOFs per node), vectorised over elements.

Per node the DOFs are (u_x, u_y, u_z, theta_x, theta_y, theta_z) in global
axes, as on the shell triangle (:mod:`solver.model.shell`).  A quadrilateral
need not be flat: its frame is the mean plane (normal along the cross product
of the diagonals, x along the mean of edges 1-2 and 4-3, origin the centroid),
its nodes are projected onto that plane, and rigid links carry each node's
motion to its projection, u_p = u - z_i theta x n, so a rigid motion of the
warped element is a rigid motion of the flat one.  On the flat quadrilateral,
in its own frame:

* **membrane**: the bilinear quadrilateral with Taylor's incompatible modes
  (QM6: u += a1 (1 - xi^2) + a2 (1 - eta^2), likewise v, their derivatives
  taken with the centre Jacobian and scaled by det J0 / det J so that the
  patch test is passed), condensed out element by element; 2 x 2 Gauss.  It
  bends in plane exactly for a rectangle;
* **drilling rotations**: the rotation omega = (dv/dx - du/dy) / 2 at the
  centre ties them, by a Hughes-Brezzi penalty gamma t A (mean theta_z -
  omega)^2, gamma = ``drilling`` x G, and a spring ``drilling`` x D / 4
  (theta_i - omega)^2 per corner at the bending scale; the drilling rotations
  strain nothing else, as in the triangle's ``cst`` membrane;
* **bending and transverse shear**: Reissner-Mindlin with the rotations
  beta = (dw/dx, dw/dy) of the Kirchhoff limit, beta_x = -theta_y, beta_y =
  theta_x; curvatures from the bilinear rotations (2 x 2 Gauss, D = E t^3 /
  (12 (1 - nu^2))); transverse shear by Dvorkin & Bathe's MITC4 (1984): the
  covariant shear strains are sampled at the edge midpoints (xi = 0, eta =
  +-1 and xi = +-1, eta = 0) and interpolated linearly across, with the shear
  modulus 5/6 G t.  Thick plates follow Mindlin; thin ones Kirchhoff, without
  shear locking.

The lumped mass gives every node the integral of its shape function times
rho t in each translation and the rotary inertia as on the triangle.
"""
from __future__ import annotations

import numpy as np

from solver.model.shell import face_mises
from solver.model.shell_membrane import drilling_springs, plane_stress

XI = np.array([-1.0, 1.0, 1.0, -1.0])
ETA = np.array([-1.0, -1.0, 1.0, 1.0])
GAUSS = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float) / np.sqrt(3.0)
SHEAR_FACTOR = 5.0 / 6.0
WARP_LIMIT = 0.1          # refused: a node farther than this x sqrt(area) from the mean plane


class BadQuad(ValueError):
    def __init__(self, index: int, what: str):
        super().__init__(f"shell element {index} {what}")
        self.index = index


def shape(xi, eta):
    """N [4] and dN/d(xi, eta) [4, 2] at one point."""
    N = 0.25 * (1 + XI * xi) * (1 + ETA * eta)
    dN = 0.25 * np.stack([XI * (1 + ETA * eta), ETA * (1 + XI * xi)], axis=1)
    return N, dN


def frames(X: np.ndarray):
    """Mean-plane frames R [e, 3, 3] (rows: local x, y, z in global axes), the
    projected 2D coordinates x [e, 4, 2], the nodes' offsets z [e, 4] from the
    plane and the projected areas A [e]."""
    normal = np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 1])
    twice = np.linalg.norm(normal, axis=1)
    ez = normal / np.maximum(twice, 1e-300)[:, None]
    along = 0.5 * (X[:, 1] + X[:, 2] - X[:, 0] - X[:, 3])
    along -= np.einsum("ei,ei->e", along, ez)[:, None] * ez
    ex = along / np.maximum(np.linalg.norm(along, axis=1), 1e-300)[:, None]
    ey = np.cross(ez, ex)
    R = np.stack([ex, ey, ez], axis=1)
    local = np.einsum("eij,eaj->eai", R, X - X.mean(axis=1, keepdims=True))
    x = local[..., :2]
    xs, ys = x[..., 0], x[..., 1]
    A = 0.5 * ((xs[:, 2] - xs[:, 0]) * (ys[:, 3] - ys[:, 1]) -
               (xs[:, 3] - xs[:, 1]) * (ys[:, 2] - ys[:, 0]))
    return R, x, local[..., 2], A


def check(X: np.ndarray):
    """Refuse degenerate, non-convex or folded quadrilaterals and those warped
    beyond WARP_LIMIT (BadQuad naming the first)."""
    R, x, z, A = frames(X)
    scale = np.maximum(np.abs(x).max(axis=(1, 2)), 1e-300)
    dets = np.stack([_jacobian(x, shape(*p)[1])[1] for p in np.vstack([GAUSS, np.c_[XI, ETA]])],
                    axis=1)
    bad = (dets <= 1e-12 * scale[:, None] ** 2).any(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise BadQuad(i, f"is degenerate or not convex (area {A[i]:.3g} m^2)")
    warp = np.abs(z).max(axis=1) / np.sqrt(A)
    if (warp > WARP_LIMIT).any():
        i = int(np.argmax(warp))
        raise BadQuad(i, f"is warped: a corner lies {warp[i]:.3g} x sqrt(area) off its mean "
                         f"plane (at most {WARP_LIMIT})")


def _jacobian(x, dN):
    """J [e, 2, 2] (rows d/dxi, d/deta of (x, y)) and det J [e]."""
    J = np.einsum("ak,eai->eki", dN, x)
    return J, J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]


def _inverse(J, det):
    inv = np.empty_like(J)
    inv[:, 0, 0], inv[:, 1, 1] = J[:, 1, 1] / det, J[:, 0, 0] / det
    inv[:, 0, 1], inv[:, 1, 0] = -J[:, 0, 1] / det, -J[:, 1, 0] / det
    return inv


def _strain_rows(g):
    """(xx, yy, 2xy) rows from a field's gradients g [e, n, 2]: [e, 3, 2n] on
    (u, v) pairs."""
    n = g.shape[1]
    B = np.zeros((g.shape[0], 3, n, 2))
    B[:, 0, :, 0] = g[..., 0]
    B[:, 1, :, 1] = g[..., 1]
    B[:, 2, :, 0] = g[..., 1]
    B[:, 2, :, 1] = g[..., 0]
    return B.reshape(g.shape[0], 3, 2 * n)


def membrane(x, A, E, nu, t, drilling):
    """QM6 membrane with the drilling penalty, local DOFs (u, v, theta_z) per
    node [e, 12, 12]."""
    n = len(A)
    D = t * plane_stress(E, nu)
    J0, det0 = _jacobian(x, shape(0.0, 0.0)[1])
    inv0 = _inverse(J0, det0)
    Kcc, Kci, Kii = np.zeros((n, 8, 8)), np.zeros((n, 8, 4)), np.zeros((n, 4, 4))
    for xi, eta in GAUSS:
        _, dN = shape(xi, eta)
        J, det = _jacobian(x, dN)
        g = np.einsum("eij,aj->eai", _inverse(J, det), dN)              # dN/dx [e, 4, 2]
        Bc = _strain_rows(g)
        dP = np.array([[-2 * xi, 0.0], [0.0, -2 * eta]])                 # d(1-xi^2, 1-eta^2)
        gi = np.einsum("eij,aj->eai", inv0, dP) * (det0 / det)[:, None, None]
        Bi = _strain_rows(gi)
        Kcc += np.einsum("eki,kl,elj->eij", Bc, D, Bc) * det[:, None, None]
        Kci += np.einsum("eki,kl,elj->eij", Bc, D, Bi) * det[:, None, None]
        Kii += np.einsum("eki,kl,elj->eij", Bi, D, Bi) * det[:, None, None]
    Km = Kcc - np.einsum("eij,ejk->eik", Kci, np.linalg.solve(Kii, Kci.transpose(0, 2, 1)))
    K = np.zeros((n, 12, 12))
    uv = np.array([0, 1, 3, 4, 6, 7, 9, 10])
    K[:, uv[:, None], uv[None, :]] = Km
    # drilling: theta_z against the centre's rotation omega
    g0 = np.einsum("eij,aj->eai", inv0, shape(0.0, 0.0)[1])
    return K + drilling_springs(g0, A, E, nu, t, drilling)


BETA = np.array([[0, 0, -1], [0, 1, 0]], dtype=float)     # (beta_x, beta_y) of (w, tx, ty)
TYING = ((0.0, 1.0, 0), (0.0, -1.0, 0), (1.0, 0.0, 1), (-1.0, 0.0, 1))   # A, C (xi); B, D (eta)


def _covariant_shear(x, xi, eta, k):
    """The covariant transverse shear e_k = dw/d(xi_k) - beta . dx/d(xi_k) at
    (xi, eta), k = 0 (xi) or 1 (eta), from (w, theta_x, theta_y) per node: [e, 12]."""
    N, dN = shape(xi, eta)
    J, _ = _jacobian(x, dN)
    row = np.zeros((len(x), 4, 3))
    row[:, :, 0] = dN[:, k]
    # - (beta_x x_,k + beta_y y_,k) with beta = BETA (w, tx, ty) interpolated by N
    row -= np.einsum("a,ed,dc->eac", N, J[:, k, :], BETA)
    return row.reshape(len(x), 12)


def bending(x, A, E, nu, t):
    """Mindlin bending + MITC4 transverse shear, local DOFs (w, theta_x,
    theta_y) per node [e, 12, 12]."""
    n = len(A)
    Db = t ** 3 / 12 * plane_stress(E, nu)
    Gs = SHEAR_FACTOR * E / (2 * (1 + nu)) * t
    tied = {(xi, eta): _covariant_shear(x, xi, eta, k) for xi, eta, k in TYING}
    K = np.zeros((n, 12, 12))
    for xi, eta in GAUSS:
        _, dN = shape(xi, eta)
        J, det = _jacobian(x, dN)
        inv = _inverse(J, det)
        g = np.einsum("eij,aj->eai", inv, dN)
        Bb = np.zeros((n, 3, 4, 3))                  # curvature of beta
        Bb[:, 0] = g[:, :, 0, None] * BETA[0]
        Bb[:, 1] = g[:, :, 1, None] * BETA[1]
        Bb[:, 2] = g[:, :, 1, None] * BETA[0] + g[:, :, 0, None] * BETA[1]
        Bb = Bb.reshape(n, 3, 12)
        e_xi = 0.5 * (1 + eta) * tied[(0.0, 1.0)] + 0.5 * (1 - eta) * tied[(0.0, -1.0)]
        e_eta = 0.5 * (1 + xi) * tied[(1.0, 0.0)] + 0.5 * (1 - xi) * tied[(-1.0, 0.0)]
        Bs = np.einsum("eij,ejk->eik", inv, np.stack([e_xi, e_eta], axis=1))
        K += (np.einsum("eki,kl,elj->eij", Bb, Db, Bb) +
              Gs * np.einsum("eki,ekj->eij", Bs, Bs)) * det[:, None, None]
    return K


MEMBRANE = (6 * np.arange(4)[:, None] + np.array([0, 1, 5])[None, :]).ravel()
BENDING = (6 * np.arange(4)[:, None] + np.array([2, 3, 4])[None, :]).ravel()


def _transform(R, z):
    """local = T global [e, 24, 24]: the frame on every 3-vector, then the
    rigid link to the projected node (u_x -= z theta_y, u_y += z theta_x)."""
    n = len(R)
    T = np.zeros((n, 24, 24))
    for b in range(8):
        T[:, 3 * b:3 * b + 3, 3 * b:3 * b + 3] = R
    for a in range(4):
        r = 6 * a
        T[:, r, r + 3:r + 6] -= z[:, a, None] * R[:, 1]          # - z theta_y (local)
        T[:, r + 1, r + 3:r + 6] += z[:, a, None] * R[:, 0]      # + z theta_x (local)
    return T


def stiffness(X: np.ndarray, E: float, nu: float, t: float, drilling: float = 1e-2) -> np.ndarray:
    """Global-axes element stiffness [e, 24, 24] of quadrilaterals X [e, 4, 3]."""
    R, x, z, A = frames(X)
    n = len(A)
    K = np.zeros((n, 24, 24))
    K[:, MEMBRANE[:, None], MEMBRANE[None, :]] = membrane(x, A, E, nu, t, drilling)
    K[:, BENDING[:, None], BENDING[None, :]] = bending(x, A, E, nu, t)
    T = _transform(R, z)
    K = np.matmul(np.matmul(T.transpose(0, 2, 1), K), T)
    return 0.5 * (K + K.transpose(0, 2, 1))


def lumped_mass(X: np.ndarray, rho: float, t: float, rotary: str = "physical") -> np.ndarray:
    """Nodal masses per element node and DOF [e, 4, 6]: rho t times the
    integral of each node's shape function in each translation; in each
    rotation that mass times t^2 / 12 ("physical") or (t^2 + A) / 12
    ("scaled", as on the triangle)."""
    _, x, _, A = frames(X)
    share = np.zeros((len(A), 4))
    for xi, eta in GAUSS:
        N, dN = shape(xi, eta)
        share += N[None, :] * _jacobian(x, dN)[1][:, None]
    m = rho * t * share
    out = np.empty((len(A), 4, 6))
    out[:, :, :3] = m[:, :, None]
    arm = t ** 2 / 12 + (A / 12 if rotary == "scaled" else 0.0 * A)
    out[:, :, 3:] = (m * arm[:, None])[:, :, None]
    return out


def resultants(X: np.ndarray, u: np.ndarray, E: float, nu: float, t: float):
    """At each element's centre, in its own frame: membrane forces N [N/m],
    moments M [N m/m] and the larger von Mises stress of the two faces [Pa],
    as :func:`solver.model.shell.resultants`.  u: element DOFs [e, 24]."""
    R, x, z, A = frames(X)
    loc = np.einsum("eij,ej->ei", _transform(R, z), u)
    _, dN = shape(0.0, 0.0)
    J, det = _jacobian(x, dN)
    g = np.einsum("eij,aj->eai", _inverse(J, det), dN)
    eps = np.einsum("eki,ei->ek", _strain_rows(g), loc[:, np.array([0, 1, 6, 7, 12, 13, 18, 19])])
    beta = np.einsum("dc,eac->ead", BETA, loc[:, BENDING].reshape(-1, 4, 3))
    kappa = np.stack([np.einsum("ea,ea->e", g[..., 0], beta[..., 0]),
                      np.einsum("ea,ea->e", g[..., 1], beta[..., 1]),
                      np.einsum("ea,ea->e", g[..., 1], beta[..., 0]) +
                      np.einsum("ea,ea->e", g[..., 0], beta[..., 1])], axis=1)
    D = plane_stress(E, nu)
    N, M = t * eps @ D.T, t ** 3 / 12 * kappa @ D.T
    return N, M, face_mises(N, M, t)
