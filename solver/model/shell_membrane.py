"""The shell triangle's membrane: three choices (``model.material.membrane``),
each a [e, 9, 9] stiffness in local DOFs (u, v, theta_z) per corner.

* ``allman``: Allman's triangle (Allman 1984) with a Hughes-Brezzi penalty
  on its one spurious mode.  The in-plane displacement is quadratic, an edge
  midpoint moving by the mean of its corners plus l/8 (theta_i - theta_j)
  along the edge's normal; the strains are integrated exactly at the edge
  midpoints.  The penalty gamma t A (mean theta_z - omega)^2, omega =
  (dv/dx - du/dy) / 2 at the centroid, gamma = ``drilling`` x G, costs a
  rigid rotation about the normal nothing.
* ``andes``: Felippa's optimal ANDES membrane "OPT" (Felippa 2003; the ANDES
  template of Felippa & Militello 1992).  K = K_b + K_h: the basic stiffness
  L D L^T / (t A) of the constant strain lumped to the corners with the
  drilling rotations (alpha_b = 3/2), plus the higher-order stiffness of the
  deviatoric rotations theta_i - omega, 3/4 beta_0 t A sum over the edge
  midpoints of Q^T T_e^T D T_e Q (natural strains along the edges, beta_1..9
  = 1, 2, 1, 0, 1, -1, -1, -1, -2, beta_0 = max((1 - 4 nu^2) / 2, 0.01)).
  A pure-bending field's energy in a rectangle of two triangles is exact
  at any aspect ratio (nu = 0); no spurious mode, so no penalty.
* ``cst``: the constant-strain triangle on the corners' translations plus the
  Hughes-Brezzi drilling penalty gamma t A (mean theta_z - omega)^2 and, on
  each corner, a spring drilling x D / 3 (theta_i - omega)^2 at the plate's
  bending scale D = E t^3 / (12 (1 - nu^2)) (the mean penalty alone leaves two
  zero-energy drilling modes per element).  The drilling rotations carry no
  membrane strain, so a facet's drilling rotation fed by its neighbours'
  bending rotations (a curved or warped surface) strains nothing.  No
  in-plane bending within an element.

docs/shells.md measures the three on the shell obstacle course.
"""
from __future__ import annotations

import numpy as np

KINDS = ("allman", "andes", "cst")

EDGES = ((0, 1), (1, 2), (2, 0))
MIDPOINTS = np.array([[0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]])
CENTRE = np.full(3, 1 / 3)


def plane_stress(E, nu):
    return E / (1 - nu ** 2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])


def gradients(x, A):
    """dL_i/dx, dL_i/dy of the area coordinates [e, 3, 2]."""
    xs, ys = x[..., 0], x[..., 1]
    j, k = [1, 2, 0], [2, 0, 1]
    b = ys[:, j] - ys[:, k]
    c = xs[:, k] - xs[:, j]
    return np.stack([b, c], axis=2) / (2 * A)[:, None, None]


def p2_gradients(g, L):
    """Gradients of the 6 quadratic shape functions (corners, then midpoints
    of edges 1-2, 2-3, 3-1) at area coordinates L: [e, 6, 2]."""
    dN = np.empty((g.shape[0], 6, 2))
    for a in range(3):
        dN[:, a] = (4 * L[a] - 1) * g[:, a]
    for m, (i, j) in enumerate(EDGES):
        dN[:, 3 + m] = 4 * (L[i] * g[:, j] + L[j] * g[:, i])
    return dN


def _omega_row(g):
    """-omega = -(dv/dx - du/dy) / 2 of the corners' field from (u, v,
    theta_z) per corner, g the shape functions' gradients where omega is
    taken [e, k, 2]: [e, 3 k] (theta_z columns zero)."""
    d = np.zeros((g.shape[0], 3 * g.shape[1]))
    d[:, 0::3] = 0.5 * g[:, :, 1]
    d[:, 1::3] = -0.5 * g[:, :, 0]
    return d


def _penalty(A, E, nu, t, drilling, d):
    """gamma t A (d . q)^2, gamma = drilling x G: [e, n, n]."""
    gamma = drilling * E / (2 * (1 + nu))
    return (gamma * t * A)[:, None, None] * np.einsum("ei,ej->eij", d, d)


def drilling_springs(g, A, E, nu, t, drilling):
    """Drilling rotations that strain nothing else: the Hughes-Brezzi penalty
    gamma t A (mean theta_z - omega)^2 on the mean and, on each corner, a
    spring drilling x D / k (theta_i - omega)^2 at the plate's bending scale
    D = E t^3 / (12 (1 - nu^2)) (so it does not lock where the membrane's
    t-scaled one would); no spurious mode is left.  g: the corners' shape
    function gradients where omega is taken [e, k, 2].  [e, 3 k, 3 k]."""
    k = g.shape[1]
    d = _omega_row(g)
    mean = d.copy()
    mean[:, 2::3] = 1.0 / k
    K = _penalty(A, E, nu, t, drilling, mean)
    spring = drilling * E * t ** 3 / (12 * (1 - nu ** 2) * k)
    for i in range(k):
        d[:, 3 * i + 2] = 1.0
        K += spring * np.einsum("ei,ej->eij", d, d)
        d[:, 3 * i + 2] = 0.0
    return K


# ------------------------------------------------------------------ Allman
def allman_map(x):
    """Quadratic in-plane displacements at the 6 nodes from (u, v, theta_z) per
    corner (Allman 1984): a midpoint moves by the mean of its edge's corners
    plus l/8 (theta_i - theta_j) along the edge's left normal.  [e, 12, 9]."""
    n = len(x)
    T = np.zeros((n, 6, 2, 9))
    for a in range(3):
        T[:, a, 0, 3 * a] = T[:, a, 1, 3 * a + 1] = 1.0
    for m, (i, j) in enumerate(EDGES):
        d = x[:, j] - x[:, i]                             # = l t; l/8 n_left = (-d_y, d_x) / 8
        left = np.stack([-d[:, 1], d[:, 0]], axis=1) / 8
        for a in (i, j):
            T[:, 3 + m, 0, 3 * a] = T[:, 3 + m, 1, 3 * a + 1] = 0.5
        T[:, 3 + m, :, 3 * i + 2] += left
        T[:, 3 + m, :, 3 * j + 2] -= left
    return T.reshape(n, 12, 9)


def _allman_strain(g, Tm, L):
    """Membrane strains (xx, yy, 2xy) at area coordinates L from (u, v,
    theta_z) per node: [e, 3, 9]."""
    n = len(g)
    dN = p2_gradients(g, L)
    B = np.zeros((n, 3, 6, 2))
    B[:, 0, :, 0] = dN[..., 0]
    B[:, 1, :, 1] = dN[..., 1]
    B[:, 2, :, 0] = dN[..., 1]
    B[:, 2, :, 1] = dN[..., 0]
    return np.einsum("ekm,emj->ekj", B.reshape(n, 3, 12), Tm)


def allman(x, A, E, nu, t, drilling):
    g = gradients(x, A)
    Tm = allman_map(x)
    D = t * plane_stress(E, nu)
    K = np.zeros((len(A), 9, 9))
    for L in MIDPOINTS:
        B = _allman_strain(g, Tm, L)
        K += np.einsum("eki,kl,elj->eij", B, D, B) * (A / 3)[:, None, None]
    # the penalty's omega: the quadratic field's rotation at the centroid
    dN = p2_gradients(g, CENTRE)
    curl = np.zeros((len(A), 6, 2))
    curl[..., 1] = 0.5 * dN[..., 0]
    curl[..., 0] = -0.5 * dN[..., 1]
    d = -np.einsum("em,emj->ej", curl.reshape(len(A), 12), Tm)
    d[:, 2::3] += 1.0 / 3
    return K + _penalty(A, E, nu, t, drilling, d)


# ------------------------------------------------------------------- ANDES
ALPHA_B = 1.5
BETA = np.array([1, 2, 1, 0, 1, -1, -1, -1, -2], dtype=float)
# Q_1, Q_2, Q_3 (rows: edges 1-2, 2-3, 3-1; columns: the corners' deviatoric
# rotations) as indices into BETA: each corner sees the same pattern, rotated
_Q_INDEX = np.array([[[0, 1, 2], [3, 4, 5], [6, 7, 8]],
                     [[8, 6, 7], [2, 0, 1], [5, 3, 4]],
                     [[4, 5, 3], [7, 8, 6], [1, 2, 0]]])


def beta0(nu):
    return max(0.5 * (1 - 4 * nu ** 2), 0.01)


def _andes_parts(x, A):
    """The basic lumping L^ (L = t/2 L^) [e, 9, 3], the natural-to-Cartesian
    strain map T_e [e, 3, 3] and the deviatoric-rotation map T_theta
    (theta_i - omega from the 9 DOFs) [e, 3, 9]."""
    n = len(A)
    L = np.zeros((n, 9, 3))
    Te = np.zeros((n, 3, 3))
    Tt = np.zeros((n, 3, 9))
    X, Y = x[..., 0], x[..., 1]
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        xkj, yjk = X[:, k] - X[:, j], Y[:, j] - Y[:, k]
        xki, xij = X[:, k] - X[:, i], X[:, i] - X[:, j]
        yik, yji = Y[:, i] - Y[:, k], Y[:, j] - Y[:, i]
        L[:, 3 * i, 0] = L[:, 3 * i + 1, 2] = yjk
        L[:, 3 * i + 1, 1] = L[:, 3 * i, 2] = xkj
        L[:, 3 * i + 2, 0] = ALPHA_B / 6 * yjk * (yik - yji)
        L[:, 3 * i + 2, 1] = ALPHA_B / 6 * xkj * (xki - xij)
        L[:, 3 * i + 2, 2] = ALPHA_B / 3 * (xki * yik - xij * yji)
        # deviatoric rotation: theta_i - omega, 4 A omega = sum (y_jk v - x_kj u)
        Tt[:, :, 3 * i] = (xkj / (4 * A))[:, None]
        Tt[:, :, 3 * i + 1] = (-yjk / (4 * A))[:, None]
        Tt[:, i, 3 * i + 2] = 1.0
    for m, (a, b) in enumerate(EDGES):
        k = 3 - a - b
        xa, xb, ya, yb = X[:, a] - X[:, k], X[:, b] - X[:, k], Y[:, a] - Y[:, k], Y[:, b] - Y[:, k]
        l2 = (X[:, b] - X[:, a]) ** 2 + (Y[:, b] - Y[:, a]) ** 2
        Te[:, :, m] = np.stack([ya * yb, xa * xb, -(ya * xb + xa * yb)], axis=1) * \
            (l2 / (4 * A ** 2))[:, None]
    return L, Te, Tt


def andes(x, A, E, nu, t):
    D = plane_stress(E, nu)
    L, Te, Tt = _andes_parts(x, A)
    K = np.einsum("eik,kl,ejl->eij", L, D, L) * (t / (4 * A))[:, None, None]
    X, Y = x[..., 0], x[..., 1]
    inv_l2 = np.stack([1 / ((X[:, b] - X[:, a]) ** 2 + (Y[:, b] - Y[:, a]) ** 2)
                       for a, b in EDGES], axis=1)                 # [e, 3]
    Q = BETA[_Q_INDEX]                                              # [corner, 3, 3]
    Dn = np.einsum("eki,kl,elj->eij", Te, D, Te)                    # natural-strain law
    Kt = np.zeros((len(A), 3, 3))
    for a, b in EDGES:                                              # edge midpoints
        Qm = (2 * A / 3)[:, None, None] * inv_l2[:, :, None] * (0.5 * (Q[a] + Q[b]))[None]
        Kt += np.einsum("eki,ekl,elj->eij", Qm, Dn, Qm)
    Kt *= (0.75 * beta0(nu) * t * A)[:, None, None]
    return K + np.einsum("eki,ekl,elj->eij", Tt, Kt, Tt)


# --------------------------------------------------------------------- CST
def _cst_strain(g):
    """Constant strains (xx, yy, 2xy) from (u, v, theta_z) per node [e, 3, 9]."""
    B = np.zeros((len(g), 3, 9))
    B[:, 0, 0::3] = g[:, :, 0]
    B[:, 1, 1::3] = g[:, :, 1]
    B[:, 2, 0::3] = g[:, :, 1]
    B[:, 2, 1::3] = g[:, :, 0]
    return B


def cst(x, A, E, nu, t, drilling):
    g = gradients(x, A)
    B = _cst_strain(g)
    K = np.einsum("eki,kl,elj->eij", B, t * plane_stress(E, nu), B) * A[:, None, None]
    return K + drilling_springs(g, A, E, nu, t, drilling)


def stiffness(kind, x, A, E, nu, t, drilling):
    """The membrane ``kind``'s stiffness [e, 9, 9] in local (u, v, theta_z)."""
    if kind == "andes":
        return andes(x, A, E, nu, t)
    if kind == "cst":
        return cst(x, A, E, nu, t, drilling)
    return allman(x, A, E, nu, t, drilling)


def centre_strain(kind, x, A):
    """The membrane strains (xx, yy, 2xy) at the centroid [e, 3, 9] (ANDES: the
    basic, lumped one; OPT's higher-order strain vanishes there)."""
    if kind == "andes":
        L, _, _ = _andes_parts(x, A)
        return L.transpose(0, 2, 1) / (2 * A)[:, None, None]
    g = gradients(x, A)
    if kind == "cst":
        return _cst_strain(g)
    return _allman_strain(g, allman_map(x), CENTRE)
