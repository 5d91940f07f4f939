"""Flat triangular shell element (3 nodes, 6 DOFs per node), vectorised over elements.

Per node the DOFs are (u_x, u_y, u_z, theta_x, theta_y, theta_z) in global
axes.  In the element's own frame (x along edge 1-2, z the normal) the
stiffness is the sum of

* **membrane with drilling rotations**: one of three, ``model.material.membrane``
  (:mod:`solver.model.shell_membrane`): Allman's triangle with a
  Hughes-Brezzi penalty (``allman``), Felippa's optimal ANDES membrane
  (``andes``), or the constant-strain triangle with the drilling penalty
  alone (``cst``), with the plane-stress law E t / (1 - nu^2);
* **bending**: the discrete Kirchhoff triangle (DKT, Batoz-Bathe-Ho 1980).
  The slopes (dw/dx, dw/dy) are quadratic; at the corners they are the nodal
  rotations (dw/dx = -theta_y, dw/dy = theta_x); at each edge midpoint the
  tangential slope is the cubic Hermite one along the edge and the normal
  slope the mean of the corners'.  The curvatures are linear; the stiffness
  is integrated exactly with the three edge-midpoint rule.  D = E t^3 / (12
  (1 - nu^2)).

and is rotated to global axes with the element frame, T^T K T.  The lumped
mass gives every node a third of rho t A in each translation and a third of
the rotary inertia in each rotation (see :func:`lumped_mass`).
"""
from __future__ import annotations

import numpy as np

from solver.model import shell_membrane as membrane
from solver.model.shell_membrane import EDGES, MIDPOINTS, CENTRE, gradients, p2_gradients, \
    plane_stress

CORNER_SLOPES = np.array([[0, 0, -1], [0, 1, 0]], dtype=float)   # (dw/dx, dw/dy) of (w, tx, ty)


class BadShell(ValueError):
    def __init__(self, index: int, area: float):
        super().__init__(f"shell element {index} is degenerate (area {area:.3g} m^2)")
        self.index = index


def frames(X: np.ndarray):
    """Element frames R [e, 3, 3] (rows: local x, y, z in global axes), local
    2D coordinates x [e, 3, 2] and areas A [e]."""
    e1 = X[:, 1] - X[:, 0]
    normal = np.cross(e1, X[:, 2] - X[:, 0])
    twice = np.linalg.norm(normal, axis=1)
    scale = np.maximum(np.linalg.norm(e1, axis=1), 1e-300) ** 2
    bad = twice <= 1e-12 * scale
    if bad.any():
        i = int(np.argmax(bad))
        raise BadShell(i, 0.5 * float(twice[i]))
    ez = normal / twice[:, None]
    ex = e1 / np.linalg.norm(e1, axis=1)[:, None]
    ey = np.cross(ez, ex)
    R = np.stack([ex, ey, ez], axis=1)
    x = np.einsum("eij,eaj->eai", R[:, :2], X - X[:, :1])
    return R, x, 0.5 * twice


def _curvature(g, S, L):
    """Curvatures (w_xx, w_yy, 2 w_xy) of the DKT slopes at L from (w,
    theta_x, theta_y) per node: [e, 3, 9]."""
    dN = p2_gradients(g, L)
    return np.stack([np.einsum("en,end->ed", dN[..., 0], S[:, :, 0]),
                     np.einsum("en,end->ed", dN[..., 1], S[:, :, 1]),
                     np.einsum("en,end->ed", dN[..., 1], S[:, :, 0]) +
                     np.einsum("en,end->ed", dN[..., 0], S[:, :, 1])], axis=1)


def _slope_map(x):
    """Slopes (dw/dx, dw/dy) at the 6 nodes of the quadratic field (3 corners,
    then midpoints of edges 1-2, 2-3, 3-1) from (w, theta_x, theta_y) per
    node: [e, 6, 2, 9]."""
    n = len(x)
    S = np.zeros((n, 6, 2, 9))
    for a in range(3):
        S[:, a, :, 3 * a:3 * a + 3] = CORNER_SLOPES
    for m, (i, j) in enumerate(EDGES):
        d = x[:, j] - x[:, i]
        length = np.linalg.norm(d, axis=1)
        tv = d / length[:, None]
        nv = np.stack([-tv[:, 1], tv[:, 0]], axis=1)
        # tangential slope: cubic Hermite derivative at the midpoint
        st = np.zeros((n, 9))
        st[:, 3 * j] += 1.5 / length
        st[:, 3 * i] -= 1.5 / length
        for a in (i, j):
            st[:, 3 * a:3 * a + 3] -= 0.25 * np.einsum("ek,kd->ed", tv, CORNER_SLOPES)
        # normal slope: the mean of the corners'
        sn = np.zeros((n, 9))
        for a in (i, j):
            sn[:, 3 * a:3 * a + 3] += 0.5 * np.einsum("ek,kd->ed", nv, CORNER_SLOPES)
        S[:, 3 + m] = tv[:, :, None] * st[:, None, :] + nv[:, :, None] * sn[:, None, :]
    return S


def bending(x, A, E, nu, t):
    """DKT bending stiffness in local DOFs (w, theta_x, theta_y) per node [e, 9, 9]."""
    g = gradients(x, A)                                   # dL/dx [e, 3, 2]
    S = _slope_map(x)                                      # [e, 6, 2, 9]
    D = t ** 3 / 12 * plane_stress(E, nu)
    K = np.zeros((len(A), 9, 9))
    for L in MIDPOINTS:
        Bk = _curvature(g, S, L)
        K += np.einsum("eki,kl,elj->eij", Bk, D, Bk) * (A / 3)[:, None, None]
    return K


MEMBRANE_DOFS = np.array([0, 1, 5])       # u, v, theta_z within a node's 6
BENDING_DOFS = np.array([2, 3, 4])        # w, theta_x, theta_y


MEMBRANE = (6 * np.arange(3)[:, None] + MEMBRANE_DOFS[None, :]).ravel()
BENDING = (6 * np.arange(3)[:, None] + BENDING_DOFS[None, :]).ravel()


def stiffness(X: np.ndarray, E: float, nu: float, t: float, drilling: float = 1e-2,
              kind: str = "allman") -> np.ndarray:
    """Global-axes element stiffness [e, 18, 18] of triangles X [e, 3, 3] with
    the membrane ``kind`` (:data:`solver.model.shell_membrane.KINDS`)."""
    R, x, A = frames(X)
    n = len(A)
    K = np.zeros((n, 18, 18))
    K[:, MEMBRANE[:, None], MEMBRANE[None, :]] = membrane.stiffness(kind, x, A, E, nu, t, drilling)
    K[:, BENDING[:, None], BENDING[None, :]] = bending(x, A, E, nu, t)
    T = np.zeros((n, 18, 18))                 # local = T global: R on every 3-vector
    for b in range(6):
        T[:, 3 * b:3 * b + 3, 3 * b:3 * b + 3] = R
    K = np.matmul(np.matmul(T.transpose(0, 2, 1), K), T)      # T^T K T, batched
    return 0.5 * (K + K.transpose(0, 2, 1))                   # symmetric to the last bit


def _local(X, u):
    """Frames, local 2D coordinates, areas and the element DOFs u [e, 18]
    (global axes) in each element's frame."""
    R, x, A = frames(X)
    loc = np.einsum("eij,ebj->ebi", R, u.reshape(len(u), 6, 3)).reshape(len(u), 18)
    return x, A, loc


def resultants(X: np.ndarray, u: np.ndarray, E: float, nu: float, t: float,
               kind: str = "allman"):
    """At each element's centroid, in its own frame (x along edge 1-2, z the
    normal): membrane forces N = t D eps (N_xx, N_yy, N_xy) [N/m], moments
    M = t^3/12 D kappa with kappa = (w_xx, w_yy, 2 w_xy) (M_xx, M_yy, M_xy)
    [N m/m], and the largest von Mises stress of the two faces,
    sigma = N / t -+ 6 M / t^2 [Pa].  u: element DOFs in global axes [e, 18]."""
    x, A, loc = _local(X, u)
    g = gradients(x, A)
    eps = np.einsum("ekj,ej->ek", membrane.centre_strain(kind, x, A), loc[:, MEMBRANE])
    kappa = np.einsum("ekj,ej->ek", _curvature(g, _slope_map(x), CENTRE), loc[:, BENDING])
    D = plane_stress(E, nu)
    N, M = t * eps @ D.T, t ** 3 / 12 * kappa @ D.T
    return N, M, face_mises(N, M, t)


def faces(N, M, t):
    """(top, middle, bottom) stresses sigma = N / t - 6 M / t^2, N / t, N / t + 6 M / t^2
    (top: +z of the cell frame) from membrane forces and moments (xx, yy, xy)
    along the last axis (linear: N, M may be coefficient rows)."""
    return N / t - 6 * M / t ** 2, N / t, N / t + 6 * M / t ** 2


def mises(s):
    """The plane-stress von Mises stress of (xx, yy, xy) along the last axis."""
    return np.sqrt(s[..., 0] ** 2 - s[..., 0] * s[..., 1] + s[..., 1] ** 2 + 3 * s[..., 2] ** 2)


def face_mises(N, M, t):
    """The larger von Mises stress of the two faces (:func:`faces`) from membrane
    forces and moments (xx, yy, xy) [e, 3]: [e]."""
    top, _, bottom = faces(N, M, t)
    return np.maximum(mises(top), mises(bottom))


def lumped_mass(X: np.ndarray, rho: float, t: float, rotary: str = "physical") -> np.ndarray:
    """Nodal masses per element node and DOF [e, 3, 6]: a third of rho t A in
    each translation; in each rotation a third of the rotary inertia,
    rho t^3 / 12 A ("physical"), or rho t A (t^2 + A) / 12 ("scaled": never
    less than a node's share of the in-plane polar inertia of the element, so
    the rotations do not set the explicit step)."""
    _, _, A = frames(X)
    m = rho * t * A / 3
    out = np.empty((len(A), 3, 6))
    out[:, :, :3] = m[:, None, None]
    arm = t ** 2 / 12 + (A / 12 if rotary == "scaled" else 0.0 * A)
    out[:, :, 3:] = (m * arm)[:, None, None]
    return out
