"""The four-node MITC4 shell (solver/model/shell_quad.py, docs/shells.md):
rigid modes of warped quadrilaterals, membrane and bending patch tests, thick
and thin plates against Mindlin and Kirchhoff (deflection and natural
frequencies), the quick obstacle course, quad and mixed meshes through a
scene, the guard's step and the refusals."""
import sys

import numpy as np
import pytest
from scipy.linalg import eigh

from conftest import ROOT, raw_scene, run_cli, run_scene, write_scene
from solver.model import shell_quad

sys.path.insert(0, str(ROOT / "benchmarks"))
from shell_course import UX, UY, UZ, RX, RY, Case, _area_forces, course, grid, quads, solve  # noqa: E402,E501

E, NU = 1e7, 0.3


def rigid_modes(X):
    out = []
    for c in range(3):
        d = np.zeros((len(X), 6))
        d[:, c] = 1.0
        out.append(d.ravel())
        w = np.zeros(3)
        w[c] = 1.0
        d = np.zeros((len(X), 6))
        d[:, :3] = np.cross(w, X)
        d[:, 3 + c] = 1.0
        out.append(d.ravel())
    return np.array(out).T


def test_rigid_body_modes_of_warped_quadrilaterals_cost_nothing():
    """40 random convex quadrilaterals, warped up to 5 % of their size and
    turned in 3D: K symmetric, the six rigid motions give no force (the rigid
    links carry them to the flat element), exactly six zero eigenvalues."""
    rng = np.random.default_rng(0)
    base = np.array([[0, 0, 0], [1, 0, 0], [1.1, 0.9, 0], [-0.1, 1.0, 0]], float)
    X = base[None] + rng.standard_normal((40, 4, 3)) * np.array([0.12, 0.12, 0.05])
    X = X @ np.linalg.qr(rng.standard_normal((3, 3)))[0].T
    shell_quad.check(X)
    K = shell_quad.stiffness(X, E, NU, 0.01)
    assert np.array_equal(K, K.transpose(0, 2, 1))
    for e in range(len(X)):
        scale = np.abs(K[e]).max()
        assert np.abs(K[e] @ rigid_modes(X[e])).max() < 1e-12 * scale
        ev = np.sort(np.abs(np.linalg.eigvalsh(K[e])))
        assert ev[5] < 1e-14 * ev[-1] and ev[6] > 1e4 * ev[5], (e, ev[:8])


def patch():
    """A 2 x 2 patch of four irregular quadrilaterals around one interior node."""
    p = np.array([[0, 0], [1.1, 0], [2, 0], [0, 0.9], [0.8, 1.2], [2, 1.1], [0, 2], [1, 2],
                  [2, 2]], float)
    q = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]])
    return p, q, np.array([4])


def solve_patch(field):
    p, q, inner = patch()
    a, b = 0.5, 0.8
    Q = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]) @ \
        np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    X = np.c_[p, np.zeros(len(p))] @ Q.T
    K = shell_quad.stiffness(X[q], E, NU, 0.01)
    Kg = np.zeros((6 * len(p), 6 * len(p)))
    dofs = (6 * q[:, :, None] + np.arange(6)).reshape(len(q), 24)
    for e in range(len(q)):
        Kg[np.ix_(dofs[e], dofs[e])] += K[e]
    exact = np.zeros((len(p), 6))
    for i, (x, y) in enumerate(p):
        loc = field(x, y)
        exact[i, :3], exact[i, 3:] = Q @ loc[:3], Q @ loc[3:]
    exact = exact.ravel()
    free = np.repeat(np.isin(np.arange(len(p)), inner), 6)
    u = exact.copy()
    u[free] = np.linalg.solve(Kg[np.ix_(free, free)], -Kg[np.ix_(free, ~free)] @ exact[~free])
    return u[free], exact[free]


@pytest.mark.parametrize("kind", ["membrane", "bending"])
def test_patch_tests(kind):
    """A linear in-plane field (its rotation as drilling) and a constant-
    curvature deflection (its slopes as rotations, no transverse shear) are
    reproduced at the interior node of an irregular patch tilted in 3D."""
    def membrane(x, y):
        u, v = 1e-3 * (1 + 2 * x - 0.5 * y), 1e-3 * (-1 + 0.7 * x + 1.5 * y)
        return np.array([u, v, 0, 0, 0, 0.5e-3 * (0.7 + 0.5)])

    def bending(x, y):
        kx, ky, kxy = 2e-3, -1e-3, 1.5e-3
        wx, wy = kx * x + 0.5 * kxy * y, ky * y + 0.5 * kxy * x
        return np.array([0, 0, 0.5 * (kx * x * x + ky * y * y + kxy * x * y), wy, -wx, 0])
    got, exact = solve_patch(membrane if kind == "membrane" else bending)
    assert np.abs(got - exact).max() < 1e-10 * np.abs(exact).max()


def plate(n, t):
    """A simply supported square plate (a = 1, hard support: w and the
    tangential rotation held on every edge, and the in-plane motion), n x n
    quadrilaterals: (points, quads, held DOF mask)."""
    pts, tri, idx = grid(n, n, lambda s, r: np.stack([s, r, 0 * s], 1))
    held = np.zeros((len(pts), 6), bool)
    for edge, rot in ((idx[0, :], RX), (idx[-1, :], RX), (idx[:, 0], RY), (idx[:, -1], RY)):
        held[edge, :3] = True
        held[edge, rot] = True
    return pts, quads(tri), held, idx


@pytest.mark.parametrize("t", [0.001, 0.1, 0.2])
def test_plates_under_pressure_follow_mindlin_and_kirchhoff(t):
    """Uniform pressure on the simply supported plate: the centre's deflection
    against Mindlin's exact w_K + M_K / (5/6 G t) (w_K = 0.00406235 q a^4 / D,
    M_K = 0.0736713 q a^2 the Kirchhoff moment sum; 0.0005 %, 5 % and 21 %
    above Kirchhoff at t / a = 0.001, 0.1, 0.2): no shear locking in the thin
    plate, error falling 4x per halving (order 2), 0.2 % at 16 x 16."""
    D, G = E * t ** 3 / (12 * (1 - NU ** 2)), E / (2 * (1 + NU))
    exact = 0.00406235 / D + 0.0736713 / (5 / 6 * G * t)
    errs = []
    for n in (8, 16):
        pts, q, held, idx = plate(n, t)
        tri = np.concatenate([q[:, :3], q[:, [0, 2, 3]]])
        case = Case("plate", pts, tri, E, NU, t, [(np.flatnonzero(held[:, c]), (c,))
                                                   for c in range(6)],
                    _area_forces(pts, tri, (0, 0, -1.0)), idx[n // 2, n // 2:n // 2 + 1], UZ,
                    -exact, f"{n}x{n}")
        errs.append(solve(case, "mitc4") - 1)
    assert -0.006 < errs[0] < 0 and -0.0015 < errs[1] < 0, errs
    assert 3.5 < errs[0] / errs[1] < 4.5, errs


def mindlin_omega(a, t, m, n, rho=1.0):
    """The lowest (flexural) frequency of mode (m, n) of the hard simply
    supported plate (Mindlin, shear factor 5/6, rotary inertia)."""
    D, kGh = E * t ** 3 / (12 * (1 - NU ** 2)), 5 / 6 * E / (2 * (1 + NU)) * t
    al, be = m * np.pi / a, n * np.pi / a
    K = np.array([[kGh * (al ** 2 + be ** 2), kGh * al, kGh * be],
                  [kGh * al, D * (al ** 2 + (1 - NU) / 2 * be ** 2) + kGh, D * (1 + NU) / 2 * al * be],
                  [kGh * be, D * (1 + NU) / 2 * al * be, D * (be ** 2 + (1 - NU) / 2 * al ** 2) + kGh]])
    M = np.diag([rho * t, rho * t ** 3 / 12, rho * t ** 3 / 12])
    return np.sqrt(eigh(K, M, eigvals_only=True)[0])


@pytest.mark.parametrize("t", [0.01, 0.1])
def test_plate_frequencies_follow_mindlin_and_kirchhoff(t):
    """The four lowest modes (1,1), (1,2), (2,1), (2,2) of the 16 x 16 plate
    with physical rotary inertia: within 1.5 % of Mindlin's (t / a = 0.1:
    3-12 % below Kirchhoff's); the thin plate (t / a = 0.01) within 1.5 % of
    Kirchhoff's."""
    pts, q, held, _ = plate(16, t)
    held[:, 5] = True            # the drilling modes (5,300 rad/s at t = 0.1) are not the plate's
    K = shell_quad.stiffness(pts[q], E, NU, t)
    m = shell_quad.lumped_mass(pts[q], 1.0, t)
    n = 6 * len(pts)
    dofs = (6 * q[:, :, None] + np.arange(6)).reshape(len(q), 24)
    Kg, mg = np.zeros((n, n)), np.zeros(n)
    for e in range(len(q)):
        Kg[np.ix_(dofs[e], dofs[e])] += K[e]
    np.add.at(mg, dofs.ravel(), m.reshape(len(q), 24).ravel())
    free = ~held.ravel()
    s = 1 / np.sqrt(mg[free])
    lam = np.linalg.eigvalsh(Kg[np.ix_(free, free)] * s[:, None] * s[None, :])
    got = np.sqrt(np.sort(lam)[:4])
    want = np.sort([mindlin_omega(1.0, t, i, j) for i, j in ((1, 1), (1, 2), (2, 1), (2, 2))])
    D = E * t ** 3 / (12 * (1 - NU ** 2))
    kirchhoff = np.sort([np.pi ** 2 * (i * i + j * j) * np.sqrt(D / t)
                         for i, j in ((1, 1), (1, 2), (2, 1), (2, 2))])
    assert np.abs(got / want - 1).max() < 0.015, got / want
    if t < 0.05:
        assert np.abs(got / kirchhoff - 1).max() < 0.015, got / kirchhoff
    else:
        assert (want / kirchhoff < 0.97).all() and want[-1] / kirchhoff[-1] < 0.9


@pytest.mark.parametrize("name, n, low, high", [
    ("hemisphere", 8, 0.98, 1.0),
    ("roof", 16, 0.99, 1.01),
    ("twist_thin_z", 2, 0.99, 1.01),
    ("straight_regular_inplane", 0, 0.98, 1.0),
    ("curved_inplane", 0, 0.87, 0.90),
])
def test_obstacle_course_quick(name, n, low, high):
    """MITC4 on the course (docs/benchmarks/bench_shells.md): no membrane
    locking on the thin hemisphere and twisted beam, in-plane bending by the
    incompatible modes."""
    assert low <= solve(course(name, n), "mitc4") <= high


def test_a_quad_and_a_mixed_plate_through_a_scene(tmp_path):
    """configs/plate_shell.yaml solved statically under 1 kN at the centre, on
    16 x 16 recombined quadrilaterals and on a body half quads, half
    triangles: Kirchhoff's w = 0.0116 P a^2 / D within 1 % and 3 %."""
    D = 210e9 * 0.01 ** 3 / (12 * (1 - 0.3 ** 2))
    geo = tmp_path / "mixed.geo"
    geo.write_text("""n = 16;
Point(1) = {0, 0, 0}; Point(2) = {0.5, 0, 0}; Point(3) = {1, 0, 0};
Point(4) = {1, 1, 0}; Point(5) = {0.5, 1, 0}; Point(6) = {0, 1, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 5}; Line(5) = {5, 6};
Line(6) = {6, 1}; Line(7) = {2, 5};
Curve Loop(1) = {1, 7, 5, 6}; Plane Surface(1) = {1};
Curve Loop(2) = {2, 3, 4, -7}; Plane Surface(2) = {2};
Transfinite Curve{1, 2, 4, 5} = n / 2 + 1; Transfinite Curve{3, 6, 7} = n + 1;
Transfinite Surface{1}; Transfinite Surface{2}; Recombine Surface{1};
Physical Surface("plate") = {1, 2};
Physical Curve("edges") = {1, 2, 3, 4, 5, 6};
""")
    for mesh, params, tol in ((str(ROOT / "meshes" / "plate_shell.geo"), {"n": 16, "quads": 1}, 0.01),
                              (str(geo), {}, 0.03)):
        raw = raw_scene("plate_shell")
        raw["model"].update(mesh=mesh, mesh_parameters=params)
        raw.update(analysis="static", time={"end": 1.0},
                   loads=[{"at": [0.5, 0.5, 0.0], "component": 2, "kind": "rectangular",
                           "amplitude": 1000.0, "duration": 2.0}])
        w = run_scene(raw, tmp_path).probes["centre"]["displacement"][0]
        assert abs(w / (0.0116 * 1000.0 / D) - 1) < tol, (mesh, w)


def test_the_guard_knows_the_quad_step(tmp_path):
    """The recombined plate with physical rotary inertia: critical step 1.96 us
    (the triangles' 1.71 us); refused at 1.01 x, runs at 0.99 x."""
    def dynamic(dt):
        raw = raw_scene("plate_shell")
        raw["model"]["mesh_parameters"] = {"n": 16, "quads": 1}
        raw["time"] = {"end": 10 * dt, "dt": dt}
        raw["output"] = {"file": str(tmp_path / f"q{dt}.h5")}
        return raw
    crit = run_scene(dynamic(1e-7), tmp_path).partitions["plate"]["critical_step"]
    assert crit == pytest.approx(1.96e-6, rel=0.01)
    for factor, code in ((1.01, 2), (0.99, 0)):
        proc = run_cli([write_scene(tmp_path / f"g{factor}.yaml", dynamic(factor * crit))])
        assert proc.returncode == code, (factor, proc.stderr)


def test_a_warped_quadrilateral_is_refused(tmp_path):
    """A quadrilateral whose corners lie 0.35 x sqrt(area) off its mean plane
    (a hypar of one element): one line naming the group, the gmsh element
    and the limit, exit 2, no output file."""
    geo = tmp_path / "warped.geo"
    geo.write_text("""Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0.7}; Point(3) = {1, 1, 0};
Point(4) = {0, 1, 0.7};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Surface(1) = {1};
Transfinite Curve{1, 2, 3, 4} = 2; Transfinite Surface{1}; Recombine Surface{1};
Physical Surface("plate") = {1}; Physical Curve("edges") = {1, 2, 3, 4};
""")
    raw = raw_scene("plate_shell")
    raw["model"].update(mesh=str(geo), mesh_parameters={})
    raw.update(analysis="static", time={"end": 1.0}, loads=[], probes=[])
    out = tmp_path / "w.h5"
    raw["output"] = {"file": str(out)}
    proc = run_cli([write_scene(tmp_path / "w.yaml", raw)])
    assert proc.returncode == 2, proc.stderr
    err, = proc.stderr.strip().splitlines()
    assert "model.body: group 'plate': gmsh element" in err and "(quad4) warped" in err, err
    assert "at most 0.1" in err and not out.exists()


def test_a_strip_of_quadrilaterals_welded_to_a_solid():
    """meshes/block_strip.geo with quads = 1: the strip of MITC4 cells tied to
    the clamped block of hexahedra; its tip deflection is beam theory's for a
    strip clamped at the weld within 1 %, as the triangles' is."""
    from test_shell import block_strip, strip_tip
    raw = block_strip()
    raw["model"]["mesh_parameters"]["quads"] = 1
    assert strip_tip(raw) == pytest.approx(1.0, abs=0.01)


def test_a_mixed_body_with_sections_and_pressure_on_two_ranks(tmp_path):
    """The stepped strip of tests/test_shell_sections.py as quads in its root
    half and ANDES triangles with a 5 mm section in its tip half (mixed.geo
    style), under a pressure, explicit, its one partition split over 2 ranks:
    the tip's history is the 1-rank run's to 1e-12."""
    import h5py
    from test_shell_sections import GEO, stepped
    raw = stepped(tmp_path, 0, analysis="dynamic", time={"end": 2e-4, "dt": 4e-7},
                  partitions=[{"name": "all", "method": "fem", "group": "strip",
                               "integrator": "explicit", "ratio": 1}],
                  loads=[{"group": "strip", "pressure": True, "kind": "half_sine",
                          "amplitude": 1.0e3, "duration": 1e-4}])
    geo = tmp_path / "mixed.geo"
    geo.write_text(GEO.replace("If (quads) Recombine Surface{1, 2}; EndIf", "Recombine Surface{1};"))
    raw["model"]["mesh"] = str(geo)
    raw["model"]["material"]["membrane"] = "andes"
    out = []
    for n in (None, 2):
        raw["output"] = {"file": str(tmp_path / f"m{n}.h5")}
        proc = run_cli([write_scene(tmp_path / f"m{n}.yaml", raw)], n=n, timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert "0.005 m on 40 cells, 0.01 m on 20 cells" in proc.stdout and "20 quadrilaterals" in proc.stdout
        with h5py.File(tmp_path / f"m{n}.h5") as f:
            out.append(f["probes/tip/displacement"][()])
    assert np.abs(out[0]).max() > 0
    assert np.abs(out[0] - out[1]).max() <= 1e-12 * np.abs(out[0]).max()
