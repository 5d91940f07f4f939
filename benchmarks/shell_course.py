"""The shell obstacle course (MacNeal & Harder 1985; Belytschko et al. 1985):
its meshes, supports, loads and reference values, solved statically with the
shell triangle of solver/model/shell.py (benchmarks/bench_shells.py, the
quick version in tests/test_shell_course.py).

Every mesh is structured: n1 x n2 quadrilaterals, each split into two
triangles on the same diagonal.  ``course(name, n)`` builds one case;
``solve(case, membrane)`` assembles K from ``shell.stiffness`` with PETSc's
COO assembly, holds the supported DOFs and solves with LU; it returns the
probe's displacement divided by the reference (1 = the reference value).

Cases (``n``: elements per side of the curved shells; across the width of the
twisted beam, 6 n along; the MacNeal-Harder beams are the literature's fixed
6 x 1 meshes):

- ``roof``: Scordelis-Lo roof (R 25, L 50, 40 deg, t 0.25, E 4.32e8, nu 0),
  self-weight 90 per unit area, diaphragm ends; a quarter; vertical
  displacement at the free edge's midspan, 0.3024;
- ``cylinder``: pinched cylinder with diaphragms (R 300, L 600, t 3, E 3e6,
  nu 0.3, P = 1); an eighth; displacement under the load, 1.8248e-5;
- ``hemisphere``: pinched hemisphere with an 18 deg hole (R 10, t 0.04,
  E 6.825e7, nu 0.3, +-2 at 90 deg intervals); a quarter with the load's
  halves; displacement under the load, 0.094;
- ``twist_thick_z``, ``twist_thick_y``, ``twist_thin_z``, ``twist_thin_y``:
  the pretwisted beam (L 12, width 1.1, twisted 90 deg, E 29e6, nu 0.22;
  thick t 0.32, P 1; thin t 0.0032, P 1e-6), clamped, tip load in z (in the
  tip's plane) or y (across it): 5.424e-3, 1.754e-3 (thick), 5.256e-3,
  1.294e-3 (thin);
- ``straight_<mesh>_<load>``: MacNeal-Harder's straight cantilever (L 6,
  width 0.2, t 0.1, E 1e7, nu 0.3) on the regular, trapezoidal and
  parallelogram 6 x 1 meshes; tip load extension 3e-5, in-plane shear 0.1081,
  out-of-plane shear 0.4321 (its twist case is left out: which quantity its
  0.03208 measures is not settled here);
- ``curved_<load>``: the curved beam (radii 4.12 and 4.32, 90 deg, t 0.1,
  E 1e7, nu 0.25), 6 x 1; tip in-plane shear 0.08734, out-of-plane 0.5022.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UX, UY, UZ, RX, RY, RZ = range(6)


@dataclass
class Case:
    name: str
    points: np.ndarray          # [n, 3]
    triangles: np.ndarray       # [e, 3]
    E: float
    nu: float
    t: float
    held: list                  # (node ids, DOF ids) pairs
    forces: np.ndarray          # [6 n]
    probe: np.ndarray           # node ids whose mean displacement is measured
    component: int
    reference: float            # signed, in the component's axis
    mesh: str


def grid(n1, n2, place):
    """Nodes place(s, t) for s, t in [0, 1] ((n1 + 1) x (n2 + 1) of them, index
    grid [n1 + 1, n2 + 1]) and the triangles of the n1 x n2 quads split on
    their (0, 0)-(1, 1) diagonals (the quads: :func:`quads`)."""
    s, t = np.meshgrid(np.linspace(0, 1, n1 + 1), np.linspace(0, 1, n2 + 1), indexing="ij")
    points = place(s.ravel(), t.ravel())
    idx = np.arange(points.shape[0]).reshape(n1 + 1, n2 + 1)
    a, b, c, d = (idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(),
                  idx[:-1, 1:].ravel())
    tri = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return points, tri, idx


def quads(tri):
    """The quadrilaterals (a, b, c, d) that :func:`grid` split into ``tri``."""
    half = len(tri) // 2
    return np.c_[tri[:half], tri[half:, 2]]


def _forces(n, loads):
    f = np.zeros(6 * n)
    for nodes, vector in loads:
        for k, w in zip(*nodes):
            f[6 * k:6 * k + 3] += w * np.asarray(vector, float)
    return f


def _edge_weights(nodes):
    """Trapezoid-rule shares of a unit load spread over the nodes of one edge."""
    w = np.ones(len(nodes))
    w[[0, -1]] = 0.5
    return nodes, w / w.sum()


def _area_forces(points, tri, traction):
    X = points[tri]
    area = 0.5 * np.linalg.norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), axis=1)
    f = np.zeros(6 * len(points))
    for a in range(3):
        for c in range(3):
            np.add.at(f, 6 * tri[:, a] + c, area / 3 * traction[c])
    return f


def _cylinder(R, L, angle):
    """(s, t) -> the cylinder x = s L, angle from the z axis t * angle."""
    return lambda s, t: np.stack([s * L, R * np.sin(t * angle), R * np.cos(t * angle)], 1)


def roof(n):
    pts, tri, idx = grid(n, n, _cylinder(25.0, 25.0, np.radians(40)))
    held = [(idx[0, :], (UY, UZ)), (idx[-1, :], (UX, RY, RZ)), (idx[:, 0], (UY, RX, RZ))]
    return Case("roof", pts, tri, 4.32e8, 0.0, 0.25, held,
                _area_forces(pts, tri, (0, 0, -90.0)), idx[-1, -1:], UZ, -0.3024, f"{n}x{n}")


def cylinder(n):
    pts, tri, idx = grid(n, n, _cylinder(300.0, 300.0, np.pi / 2))
    held = [(idx[0, :], (UY, UZ)), (idx[-1, :], (UX, RY, RZ)), (idx[:, 0], (UY, RX, RZ)),
            (idx[:, -1], (UZ, RX, RY))]
    f = _forces(len(pts), [((idx[-1, :1], [1.0]), (0, 0, -0.25))])
    return Case("cylinder", pts, tri, 3e6, 0.3, 3.0, held, f, idx[-1, :1], UZ, -1.8248e-5,
                f"{n}x{n}")


def hemisphere(n):
    R, hole = 10.0, np.radians(18)

    def place(s, t):
        polar = np.pi / 2 - (np.pi / 2 - hole) * t          # t = 0: the equator
        return R * np.stack([np.sin(polar) * np.cos(s * np.pi / 2),
                             np.sin(polar) * np.sin(s * np.pi / 2), np.cos(polar)], 1)
    pts, tri, idx = grid(n, n, place)
    held = [(idx[0, :], (UY, RX, RZ)), (idx[-1, :], (UX, RY, RZ)), (idx[:1, 0], (UZ,))]
    f = _forces(len(pts), [((idx[:1, 0], [1.0]), (1.0, 0, 0)), ((idx[-1:, 0], [1.0]), (0, -1.0, 0))])
    return Case("hemisphere", pts, tri, 6.825e7, 0.3, 0.04, held, f, idx[:1, 0], UX, 0.094,
                f"{n}x{n}")


TWIST_REFERENCE = {("thick", UZ): 5.424e-3, ("thick", UY): 1.754e-3,
                   ("thin", UZ): 5.256e-3, ("thin", UY): 1.294e-3}


def twist(n, wall, axis):
    L, width = 12.0, 1.1
    pts, tri, idx = grid(6 * n, n, lambda s, t: np.stack(
        [s * L, (t - 0.5) * width * np.cos(s * np.pi / 2),
         (t - 0.5) * width * np.sin(s * np.pi / 2)], 1))
    t, P = (0.32, 1.0) if wall == "thick" else (0.0032, 1e-6)
    axis = UZ if axis == "z" else UY
    load = np.zeros(3)
    load[axis] = P
    f = _forces(len(pts), [(_edge_weights(idx[-1, :]), load)])
    name = f"twist_{wall}_{'z' if axis == UZ else 'y'}"
    return Case(name, pts, tri, 29e6, 0.22, t, [(idx[0, :], range(6))], f, idx[-1, :], axis,
                TWIST_REFERENCE[(wall, axis)], f"{6 * n}x{n}")


STRAIGHT_REFERENCE = {"extension": (UX, 3e-5), "inplane": (UY, 0.1081),
                      "outplane": (UZ, 0.4321)}


def straight(mesh, load):
    L, width = 6.0, 0.2

    def place(s, t):
        column = np.round(s * 6).astype(int)
        inner = (column > 0) & (column < 6)
        if mesh == "trapezoid":          # edges at +-45 deg, alternating
            x = s * L + np.where(inner, np.where(column % 2 == 1, 1.0, -1.0), 0.0) * (t - 0.5) * width
        elif mesh == "parallelogram":    # edges at 45 deg
            x = s * L + np.where(inner, (t - 0.5) * width, 0.0)
        else:
            x = s * L
        return np.stack([x, t * width, 0 * s], 1)
    pts, tri, idx = grid(6, 1, place)
    axis, ref = STRAIGHT_REFERENCE[load]
    tip = idx[-1, :]
    vector = np.zeros(3)
    vector[axis] = 1.0
    return Case(f"straight_{mesh}_{load}", pts, tri, 1e7, 0.3, 0.1, [(idx[0, :], range(6))],
                _forces(len(pts), [(_edge_weights(tip), vector)]), tip, axis, ref, "6x1")


def curved(load):
    inner, outer = 4.12, 4.32
    pts, tri, idx = grid(6, 1, lambda s, t: np.stack(
        [(inner + t * (outer - inner)) * np.cos(s * np.pi / 2),
         (inner + t * (outer - inner)) * np.sin(s * np.pi / 2), 0 * s], 1))
    tip = idx[-1, :]
    axis, ref, vector = (UY, 0.08734, (0, 1.0, 0)) if load == "inplane" else \
        (UZ, 0.5022, (0, 0, 1.0))              # in plane: across the tip (radial), shear
    return Case(f"curved_{load}", pts, tri, 1e7, 0.25, 0.1, [(idx[0, :], range(6))],
                _forces(len(pts), [(_edge_weights(tip), vector)]), tip, axis, ref, "6x1")


REFINED = ("roof", "cylinder", "hemisphere", "twist_thick_z", "twist_thick_y", "twist_thin_z",
           "twist_thin_y")
FIXED = tuple(f"straight_{m}_{ld}" for m in ("regular", "trapezoid", "parallelogram")
              for ld in STRAIGHT_REFERENCE) + ("curved_inplane", "curved_outplane")


def course(name: str, n: int = 0) -> Case:
    """The case ``name`` (REFINED ones on the n-per-side mesh)."""
    if name in ("roof", "cylinder", "hemisphere"):
        return globals()[name](n)
    if name.startswith("twist_"):
        _, wall, axis = name.split("_")
        return twist(n, wall, axis)
    if name.startswith("straight_"):
        _, mesh, load = name.split("_")
        return straight(mesh, load)
    return curved(name.split("_")[1])


def solve(case: Case, element: str, drilling: float = 1e-2) -> float:
    """The probe's mean displacement / the reference, with the shell triangle
    of membrane ``element`` (allman, andes, cst) or the quadrilateral (mitc4)."""
    from solver.model import shell, shell_quad
    from solver.petscutil import aij, init
    P = init()
    n = 6 * len(case.points)
    if element == "mitc4":
        cells = quads(case.triangles)
        K = shell_quad.stiffness(case.points[cells], case.E, case.nu, case.t, drilling)
    else:
        cells = case.triangles
        K = shell.stiffness(case.points[cells], case.E, case.nu, case.t, drilling, element)
    k = K.shape[1]
    dofs = (6 * cells[:, :, None] + np.arange(6)).reshape(len(cells), k)
    rows = np.repeat(dofs, k, axis=1).ravel()
    cols = np.tile(dofs, (1, k)).ravel()
    A = aij(rows, cols, K.ravel(), n, P.COMM_SELF, "course_")
    held = np.unique(np.concatenate([(6 * np.asarray(nodes)[:, None] + np.asarray(list(d))).ravel()
                                     for nodes, d in case.held]))
    A.zeroRowsColumns(held.astype(P.IntType), diag=1.0)
    f = case.forces.copy()
    f[held] = 0.0
    b, x = A.createVecs()
    b.getArray()[:] = f
    ksp = P.KSP().create(P.COMM_SELF)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.setOperators(A)
    ksp.solve(b, x)
    u = x.getArray().copy()
    for obj in (ksp, A, b, x):
        obj.destroy()
    return float(np.mean(u[6 * case.probe + case.component]) / case.reference)
