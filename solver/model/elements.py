"""Linear elastic element kernels, vectorised over elements (numpy only).

One isoparametric path serves the four families:

    tri3   linear triangle (plane stress with thickness, or plane strain), 1-point rule
    quad4  bilinear quadrilateral, 2x2 Gauss
    tet4   linear tetrahedron, 1-point rule
    hex8   trilinear hexahedron, 2x2x2 Gauss

Each family is one declared :class:`Family` object (its gmsh type, meshio and
XDMF names, facet family, simplex flag, quadrature, lumping rule, ...),
registered in ``CELLS`` (every cell family a mesh holds, with ``by_gmsh`` and
``by_meshio``) and, for the four body families, in ``FAMILIES``; code asks the
family for these facts instead of keeping tables of family names.

Node orderings are gmsh's.  Element DOFs are node-major ([u_x, u_y(, u_z)] per
node), matching the global numbering ``node * dim + component`` (block size
= dim).  ``stiffness`` returns K_e [n_el, nd, nd]; ``lumped_mass`` returns the
row sums of the consistent mass, rho * integral of N_a, per node [n_el, n_nodes].
An element whose Jacobian determinant is not positive at a quadrature point
(inverted or degenerate) is refused, naming the element; ``lumped_mass`` also
checks it at the corners of quad4 and hex8 cells, so a non-convex cell (a
"dart", whose reflex corner maps inside out) is refused though its Gauss
points are fine.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

G = 1.0 / np.sqrt(3.0)


@dataclass(frozen=True)
class Family:
    """An element family and every fact the code asks of it (one object per
    family, registered in :data:`CELLS`; the body families also in :data:`FAMILIES`).

    ``basis(xi)`` gives N and dN/dxi; ``points``/``weights`` the quadrature;
    ``gmsh``/``meshio``/``xdmf`` the type number and names of the formats;
    ``facet`` the family of its boundary cells; ``simplex``: the reference cell
    is the unit simplex (xi >= 0, sum xi <= 1; the Jacobian is constant);
    ``centre`` the reference centroid; ``corners`` the reference corner
    coordinates where the Jacobian is checked (None: simplices); ``mirror``
    the node order that reverses a cell's orientation; ``lumping``:
    ``row_sum`` (rho * integral N_a, the consistent mass's row sums) or
    ``row_sum_rotary`` (with a rotary inertia per node, shells);
    ``rotations``: its nodes carry rotations (shells: the plate wave bounds
    its step); ``body``: it has the stiffness and mass kernels, so it fills a
    body; ``mesh_cells``: the mesh family its cells are read as."""

    name: str
    dim: int
    n_nodes: int
    points: np.ndarray       # quadrature points [n_q, dim]
    weights: np.ndarray      # [n_q]
    basis: object = None     # xi [n, dim] -> (N [n, n_nodes], dN/dxi [n, n_nodes, dim])
    gmsh: int | None = None
    meshio: str | None = None
    xdmf: str | None = None
    facet: str | None = None
    simplex: bool = False
    centre: tuple = ()
    corners: np.ndarray | None = None
    mirror: tuple | None = None
    lumping: str | None = None
    rotations: bool = False
    body: bool = False
    mesh_cells: str | None = None

    def shape(self, xi):
        """N [n_q, n_nodes] and dN/dxi [n_q, n_nodes, dim] at points ``xi``."""
        return self.basis(np.asarray(xi, dtype=float))


def _point(xi):
    return np.ones((len(xi), 1)), np.zeros((len(xi), 1, 0))


def _line2(xi):
    x = xi[:, 0]
    N = np.stack([0.5 * (1 - x), 0.5 * (1 + x)], axis=1)
    dN = np.broadcast_to(np.array([[-0.5], [0.5]]), (len(xi), 2, 1))
    return N, dN


def _tri3(xi):
    x, y = xi[:, 0], xi[:, 1]
    N = np.stack([1 - x - y, x, y], axis=1)
    dN = np.broadcast_to(np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]), (len(xi), 3, 2))
    return N, dN


def _tet4(xi):
    x, y, z = xi.T
    N = np.stack([1 - x - y - z, x, y, z], axis=1)
    dN = np.broadcast_to(np.vstack([-np.ones(3), np.eye(3)]), (len(xi), 4, 3))
    return N, dN


QUAD_NODES = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
HEX_NODES = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                      [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)


def _tensor(nodes, xi):
    f = 1 + xi[:, None, :] * nodes[None, :, :]           # [n_q, n_nodes, dim]
    scale = 0.5 ** nodes.shape[1]
    N = scale * np.prod(f, axis=2)
    dN = np.empty_like(f)
    for d in range(nodes.shape[1]):
        others = np.prod(np.delete(f, d, axis=2), axis=2)
        dN[:, :, d] = scale * nodes[None, :, d] * others
    return N, dN


def _quad4(xi):
    return _tensor(QUAD_NODES, xi)


def _hex8(xi):
    return _tensor(HEX_NODES, xi)


class Families(Mapping):
    """A registry of element families: name -> Family, and the same families
    by gmsh type number (``by_gmsh``) and by meshio cell name (``by_meshio``)."""

    def __init__(self):
        self._named = {}

    def register(self, family: Family) -> Family:
        for other in self._named.values():
            for fact in ("name", "gmsh", "meshio"):
                value = getattr(family, fact)
                if value is not None and getattr(other, fact) == value:
                    raise ValueError(f"element family {family.name}: {fact} {value!r} is "
                                     f"already {other.name}'s")
        self._named[family.name] = family
        return family

    def __getitem__(self, name) -> Family:
        return self._named[name]

    def __iter__(self):
        return iter(self._named)

    def __len__(self) -> int:
        return len(self._named)

    @property
    def by_gmsh(self) -> dict:
        return {f.gmsh: f for f in self._named.values() if f.gmsh is not None}

    @property
    def by_meshio(self) -> dict:
        return {f.meshio: f for f in self._named.values() if f.meshio is not None}

    def facets(self) -> tuple:
        """The names of the families that bound these (edges and faces)."""
        return tuple(dict.fromkeys(f.facet for f in self._named.values() if f.facet))


CELLS = Families()           # every cell family a mesh may hold
FAMILIES = Families()        # the body families (element kernels): tri3, quad4, tet4, hex8


def register(family: Family) -> Family:
    """Declare ``family``: in CELLS, and in FAMILIES when it fills a body."""
    CELLS.register(family)
    if family.body:
        FAMILIES.register(family)
    return family


POINT = register(Family("point", 0, 1, np.zeros((1, 0)), np.ones(1), _point, gmsh=15,
                        meshio="vertex", xdmf="Polyvertex", simplex=True, mesh_cells="point"))
LINE2 = register(Family("line2", 1, 2, np.array([[-G], [G]]), np.ones(2), _line2, gmsh=1,
                        meshio="line", xdmf="Polyline", facet="point", centre=(0.0,),
                        mesh_cells="line2"))
TRI3 = register(Family("tri3", 2, 3, np.array([[1 / 3, 1 / 3]]), np.array([0.5]), _tri3, gmsh=2,
                       meshio="triangle", xdmf="Triangle", facet="line2", simplex=True,
                       centre=(1 / 3, 1 / 3), mirror=(0, 2, 1), lumping="row_sum", body=True,
                       mesh_cells="tri3"))
QUAD4 = register(Family("quad4", 2, 4, np.array([[a, b] for b in (-G, G) for a in (-G, G)]),
                        np.ones(4), _quad4, gmsh=3, meshio="quad", xdmf="Quadrilateral",
                        facet="line2", centre=(0.0, 0.0), corners=QUAD_NODES,
                        mirror=(0, 3, 2, 1), lumping="row_sum", body=True, mesh_cells="quad4"))
TET4 = register(Family("tet4", 3, 4, np.array([[0.25, 0.25, 0.25]]), np.array([1 / 6]), _tet4,
                       gmsh=4, meshio="tetra", xdmf="Tetrahedron", facet="tri3", simplex=True,
                       centre=(0.25, 0.25, 0.25), mirror=(0, 2, 1, 3), lumping="row_sum",
                       body=True, mesh_cells="tet4"))
HEX8 = register(Family("hex8", 3, 8, np.array([[a, b, c] for c in (-G, G) for b in (-G, G)
                                               for a in (-G, G)]), np.ones(8), _hex8, gmsh=5,
                       meshio="hexahedron", xdmf="Hexahedron", facet="quad4", centre=(0.0,) * 3,
                       corners=HEX_NODES, mirror=(0, 3, 2, 1, 4, 7, 6, 5), lumping="row_sum",
                       body=True, mesh_cells="hex8"))


@dataclass(frozen=True)
class Elastic:
    """Linear elastic material. ``kind``: plane_stress (with ``thickness``),
    plane_strain, or solid (3D)."""

    E: float
    nu: float
    rho: float
    kind: str = "solid"
    thickness: float = 1.0
    integration: str = "full"     # selective: the lambda term at the centre; reduced: all of it
    hourglass: float = 0.1        # reduced: the hourglass stiffness coefficient

    def D(self) -> np.ndarray:
        E, nu = self.E, self.nu
        if self.kind == "plane_stress":
            return E / (1 - nu ** 2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
        if self.kind == "plane_strain":
            c = E / ((1 + nu) * (1 - 2 * nu))
            return c * np.array([[1 - nu, nu, 0], [nu, 1 - nu, 0], [0, 0, (1 - 2 * nu) / 2]])
        lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
        D = np.zeros((6, 6))
        D[:3, :3] = lam
        D[np.arange(3), np.arange(3)] += 2 * mu
        D[np.arange(3, 6), np.arange(3, 6)] = mu
        return D

    def lame(self) -> tuple[float, float]:
        """(lambda, mu) of the in-plane or 3D law; plane stress uses
        lambda* = 2 lambda mu / (lambda + 2 mu), so D matches :meth:`D`."""
        E, nu = self.E, self.nu
        mu = E / (2 * (1 + nu))
        if self.kind == "plane_stress":
            return E * nu / (1 - nu ** 2), mu
        return E * nu / ((1 + nu) * (1 - 2 * nu)), mu

    def measure(self) -> float:
        """Out-of-plane factor of the volume integral (thickness in 2D)."""
        return self.thickness if self.kind == "plane_stress" else 1.0


def elastic(material, integration: str = "full", hourglass: float = 0.1) -> Elastic:
    """The law of a scene's ``model.material`` (thickness 1 where it gives none),
    its cells integrated as ``model.integration`` says."""
    return Elastic(material.E, material.nu, material.rho, material.kind,
                   material.thickness if material.thickness is not None else 1.0, integration,
                   hourglass)


class BadElement(ValueError):
    def __init__(self, index: int, detj: float, corner: int | None = None):
        what = ("inverted or degenerate" if corner is None else
                f"non-convex or inverted (at its corner node {corner}")
        super().__init__(f"element {index} is {what}" +
                         (f" (Jacobian determinant {detj:.3g})" if corner is None else
                          f", Jacobian determinant {detj:.3g})"))
        self.index = index
        self.detj = detj
        self.corner = corner


def check_corners(family: Family, X: np.ndarray):
    """Refuse (BadElement) a cell whose Jacobian determinant is negative at a
    corner (a non-convex quad4 or hex8: positive at the Gauss points, inside
    out near the reflex corner).  Beyond rounding only: a straight angle or a
    collapsed corner (determinant 0) is left to the Gauss-point check."""
    nodes = family.corners
    if nodes is None or not len(X):             # simplices: the Jacobian is constant
        return
    _, dN = family.shape(nodes)
    det = determinant(jacobian(dN, X))                         # [e, corner]
    scale = np.abs(det).max(axis=1, keepdims=True)
    bad = det < -1e-10 * scale
    if bad.any():
        e, q = np.argwhere(bad)[0]
        raise BadElement(int(e), float(det[e, q]), int(q))


def jacobian(dN: np.ndarray, X: np.ndarray) -> np.ndarray:
    """J [e, q, i, j] = dx_j / dxi_i from shape derivatives dN [q, a, i] and
    coordinates X [e, a, d] (one BLAS product; einsum's loop took 7 of the 11 s
    that lumping the 2.27 M-DOF bar's masses took)."""
    return np.tensordot(X, dN, axes=([1], [1])).transpose(0, 2, 3, 1)


def determinant(J: np.ndarray) -> np.ndarray:
    """det of every [..., d, d] block: the cofactor formula for d <= 3 (a few
    vector operations, not a LAPACK call per block)."""
    d = J.shape[-1]
    if d == 1:
        return J[..., 0, 0].copy()
    if d == 2:
        return J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    if d == 3:
        return (J[..., 0, 0] * (J[..., 1, 1] * J[..., 2, 2] - J[..., 1, 2] * J[..., 2, 1])
                - J[..., 0, 1] * (J[..., 1, 0] * J[..., 2, 2] - J[..., 1, 2] * J[..., 2, 0])
                + J[..., 0, 2] * (J[..., 1, 0] * J[..., 2, 1] - J[..., 1, 1] * J[..., 2, 0]))
    return np.linalg.det(J)


DEGENERATE = 1e-12   # det J below this x the product of J's row norms: a flat or collapsed cell


def quadrature(family: Family, X: np.ndarray, gradients: bool = True):
    """(N [q, a], dN/dx [e, q, a, d], w*detJ [e, q]) for coordinates X [e, a, d];
    ``gradients`` False: dN/dx is None (masses and volumes need only w*detJ)."""
    N, dN = family.shape(family.points)
    J = jacobian(dN, X)                              # J_ij = dx_j / dxi_i  [e, q, i, j]
    detJ = determinant(J)
    # degenerate within rounding counts as inverted: the closed form can leave a
    # singular J a determinant of +1e-18 (|det J| <= the product of its row norms)
    bad = detJ <= DEGENERATE * np.prod(np.linalg.norm(J, axis=-1), axis=-1)
    if bad.any():
        e, q = np.argwhere(bad)[0]
        raise BadElement(int(e), float(detJ[e, q]))
    if not gradients:
        return N, None, detJ * family.weights
    return N, physical(dN, J), detJ * family.weights


def physical(dN: np.ndarray, J: np.ndarray) -> np.ndarray:
    """dN/dx [e, q, a, i] from dN/dxi [q, a, j] and J [e, q, i, j]:
    dN/dx_i = (J^-1)_ij dN/dxi_j, [q, a, j] @ (J^-1)^T [e, q, j, i]."""
    return np.matmul(dN[None], np.linalg.inv(J).transpose(0, 1, 3, 2))


def strain_matrix(dNdx: np.ndarray) -> np.ndarray:
    """B [e, q, n_strain, n_nodes*dim] (Voigt: 2D xx, yy, xy; 3D xx, yy, zz, yz, xz, xy)."""
    e, q, a, d = dNdx.shape
    if d == 2:
        B = np.zeros((e, q, 3, a, 2))
        B[:, :, 0, :, 0] = dNdx[..., 0]
        B[:, :, 1, :, 1] = dNdx[..., 1]
        B[:, :, 2, :, 0] = dNdx[..., 1]
        B[:, :, 2, :, 1] = dNdx[..., 0]
    else:
        B = np.zeros((e, q, 6, a, 3))
        for i in range(3):
            B[:, :, i, :, i] = dNdx[..., i]
        for row, (i, j) in zip((3, 4, 5), ((1, 2), (0, 2), (0, 1))):
            B[:, :, row, :, i] = dNdx[..., j]
            B[:, :, row, :, j] = dNdx[..., i]
    return B.reshape(e, q, B.shape[2], a * d)


CHUNK = 8192        # elements per kernel call (bounds the temporaries)


def stiffness(family: Family, X: np.ndarray, material: Elastic) -> np.ndarray:
    """Element stiffness matrices K_e [n_el, n_nodes*dim, n_nodes*dim].

    For an isotropic material (every Elastic is) in Lame form,
    K_ab,ij = sum_q w detJ (lam N_a,i N_b,j + mu N_a,j N_b,i + mu delta_ij N_a,k N_b,k),
    which is B^T D B without forming B: one batched (n_q) product per element.
    ``material.integration`` selective: the lambda (volumetric) term is
    integrated at the cell centre, N_a,i N_b,j there times the cell's measure
    (Hughes 1980, "Generalization of selective integration procedures to
    anisotropic and nonlinear media", Int. J. Numer. Meth. Eng. 15: B-bar for
    an isotropic law): no volumetric locking."""
    n_el, k = X.shape[0], family.n_nodes
    d = family.dim
    lam, mu = material.lame()
    scale = material.measure()
    K = np.empty((n_el, k * d, k * d))
    selective = material.integration == "selective" and len(family.weights) > 1
    if material.integration == "reduced" and len(family.weights) > 1:
        for s in range(0, n_el, CHUNK):
            K[s:s + CHUNK] = _reduced(family, X[s:s + CHUNK], material, lam, mu, scale)
        return K
    for s in range(0, n_el, CHUNK):
        try:
            _, dNdx, wdet = quadrature(family, X[s:s + CHUNK])
        except BadElement as e:
            raise BadElement(e.index + s, e.detj) from None
        e = dNdx.shape[0]
        g = dNdx.reshape(e, -1, k * d)                               # [e, q, (a, i)]
        T = np.matmul(g.transpose(0, 2, 1), g * (scale * wdet)[:, :, None])   # [e, (a,i), (b,j)]
        T = T.reshape(e, k, d, k, d)
        Ke = lam * (T if not selective else _centre_term(family, X[s:s + CHUNK], wdet, scale)) \
            + mu * T.transpose(0, 1, 4, 3, 2)                        # lam N_a,i N_b,j + mu N_a,j N_b,i
        tr = np.einsum("eakbk->eab", T)                              # grad N_a . grad N_b
        Ke += mu * tr[:, :, None, :, None] * np.eye(d)[None, None, :, None, :]
        K[s:s + CHUNK] = Ke.reshape(e, k * d, k * d)
    return K


def _reduced(family: Family, X: np.ndarray, material: Elastic, lam, mu, scale) -> np.ndarray:
    """One-point K_e with Flanagan & Belytschko's (1981) mean gradients b =
    (1/V) integral of dN/dx (exact for a linear field on any cell, so the
    patch test holds; the centre's gradient on a 2D quad), V b^T D b, plus
    their hourglass stiffness: for each hourglass base h (the products xi eta
    (, eta zeta, zeta xi, xi eta zeta) of the nodes' reference coordinates)
    its vector gamma = h - sum_i (h . x_i) b_i, orthogonal to every linear
    field, gets c 2 mu V |b|^2 / dim gamma gamma^T on each displacement
    component (c = ``material.hourglass``; on the shear modulus, so that it
    does not lock as nu -> 0.5)."""
    try:
        _, dNdx, wdet = quadrature(family, X)
    except BadElement as e:
        raise BadElement(e.index, e.detj) from None
    e, k, d = X.shape[0], family.n_nodes, family.dim
    measure = scale * wdet.sum(axis=1)
    b = np.einsum("eq,eqai->eai", wdet, dNdx) / wdet.sum(axis=1)[:, None, None]   # mean grad N
    T = np.einsum("e,eai,ebj->eaibj", measure, b, b)
    Ke = lam * T + mu * T.transpose(0, 1, 4, 3, 2)
    Ke += mu * np.einsum("eaibi->eab", T)[:, :, None, :, None] * np.eye(d)[None, None, :, None, :]
    ref = family.corners
    bases = [ref[:, 0] * ref[:, 1]] if d == 2 else \
        [ref[:, 1] * ref[:, 2], ref[:, 2] * ref[:, 0], ref[:, 0] * ref[:, 1],
         ref[:, 0] * ref[:, 1] * ref[:, 2]]
    c = material.hourglass * 2 * mu * measure * np.einsum("eai,eai->e", b, b) / d
    H = np.zeros((e, k, k))
    for h in bases:
        gamma = h[None, :] - np.einsum("a,eai,ebi->eb", h, X, b)           # [e, a]
        H += c[:, None, None] * np.einsum("ea,eb->eab", gamma, gamma)
    Ke += H[:, :, None, :, None] * np.eye(d)[None, None, :, None, :]
    return Ke.reshape(e, k * d, k * d)


def _centre_term(family: Family, X: np.ndarray, wdet: np.ndarray, scale: float) -> np.ndarray:
    """N_a,i N_b,j at the cell centre times the cell's measure [e, a, i, b, j]."""
    _, dN = family.shape(np.array([family.centre]))
    g = physical(dN, jacobian(dN, X))[:, 0]                         # [e, a, i]
    measure = scale * wdet.sum(axis=1)                               # the cell's area or volume
    return np.einsum("e,eai,ebj->eaibj", measure, g, g)


def lumped_mass(family: Family, X: np.ndarray, material: Elastic) -> np.ndarray:
    """Nodal masses rho * integral(N_a) per element node [n_el, n_nodes]
    (in chunks: the geometry temporaries stay small on large meshes); every
    Jacobian is checked, at the corners too (:func:`check_corners`)."""
    out = np.empty((X.shape[0], family.n_nodes))
    for s in range(0, X.shape[0], CHUNK):
        try:
            N, _, wdet = quadrature(family, X[s:s + CHUNK], gradients=False)
            check_corners(family, X[s:s + CHUNK])
        except BadElement as e:
            raise BadElement(e.index + s, e.detj, e.corner) from None
        out[s:s + CHUNK] = material.rho * material.measure() * np.einsum("eq,qa->ea", wdet, N)
    return out


def volumes(family: Family, X: np.ndarray) -> np.ndarray:
    _, _, wdet = quadrature(family, X, gradients=False)
    return wdet.sum(axis=1)
