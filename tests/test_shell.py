"""Flat triangular shell (solver/model/shell.py, docs/shells.md): rigid-body
modes, membrane and bending patch tests, a cantilever strip against beam
theory, the simply supported plate's and the free ring's natural frequencies
against the analytic ones with their convergence, runs and bad inputs."""
import numpy as np
import pytest

from conftest import ROOT, refused, run_cli
from solver.model import shell
from solver.model.shell_membrane import KINDS

E, NU, T = 210e9, 0.3, 0.01


def rigid_modes(X):
    """The 6 rigid-body motions of a triangle's nodes X [3, 3] (18-vectors)."""
    out = []
    for c in range(3):
        d = np.zeros((3, 6))
        d[:, c] = 1.0
        out.append(d.ravel())
        w = np.zeros(3)
        w[c] = 1.0
        d = np.zeros((3, 6))
        d[:, :3] = np.cross(w, X)
        d[:, 3 + c] = 1.0
        out.append(d.ravel())
    return np.array(out).T


@pytest.mark.parametrize("kind", KINDS)
def test_rigid_body_modes_cost_nothing(kind):
    """Random triangles in 3D (slivers of aspect 67 among them), each membrane:
    K is symmetric, the six rigid motions give zero force and K has exactly
    six zero eigenvalues (the seventh 1e4 x the sixth: ANDES's sliver spans
    13 decades, so a threshold relative to the largest would not do)."""
    X = np.random.default_rng(0).standard_normal((50, 3, 3))
    K = shell.stiffness(X, E, NU, T, kind=kind)
    scale = np.abs(K).max(axis=(1, 2))
    assert np.abs(K - K.transpose(0, 2, 1)).max(axis=(1, 2)).max() < 1e-13 * scale.min()
    for e in range(len(X)):
        assert np.abs(K[e] @ rigid_modes(X[e])).max() < 1e-11 * scale[e]
        ev = np.sort(np.abs(np.linalg.eigvalsh(K[e])))
        assert ev[5] < 1e-13 * ev[-1] and ev[6] > 1e4 * ev[5], (e, ev[:8])


def tilted_frame():
    a, b = 0.5, 0.8
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    return Rx @ Rz                                      # columns: local x, y, z in global axes


def patch():
    """An irregular patch: 8 boundary nodes around a 2 x 2 square, 4 interior
    nodes off-grid; 14 triangles.  (local 2D points, triangles, interior ids)"""
    p = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [2, 2], [1, 2], [0, 2], [0, 1],
                  [0.6, 0.7], [1.3, 0.6], [1.4, 1.3], [0.7, 1.4]], float)
    tri = np.array([[0, 1, 8], [1, 9, 8], [1, 2, 9], [2, 3, 9], [3, 10, 9], [3, 4, 10],
                    [4, 5, 10], [5, 11, 10], [5, 6, 11], [6, 7, 11], [7, 8, 11], [7, 0, 8],
                    [8, 9, 10], [8, 10, 11]])
    return p, tri, np.arange(8, 12)


def solve_patch(local_field, kind="allman"):
    """Prescribe ``local_field`` (6 local DOFs per node of the 2D points) on the
    boundary of the tilted patch, solve for the interior: (computed, exact)
    interior DOFs in global axes."""
    p, tri, inner = patch()
    Q = tilted_frame()
    X = np.c_[p, np.zeros(len(p))] @ Q.T + np.array([0.3, -0.2, 0.1])
    K = assemble(X, tri, kind)
    exact = np.zeros((len(p), 6))
    for i, q in enumerate(p):
        loc = local_field(*q)
        exact[i, :3] = Q @ loc[:3]
        exact[i, 3:] = Q @ loc[3:]
    exact = exact.ravel()
    free = np.zeros(len(p), bool)
    free[inner] = True
    free = np.repeat(free, 6)
    u = exact.copy()
    u[free] = np.linalg.solve(K[np.ix_(free, free)], -K[np.ix_(free, ~free)] @ exact[~free])
    return u[free], exact[free]


def assemble(X, tri, kind="allman"):
    K = shell.stiffness(X[tri], E, NU, T, kind=kind)
    dofs = (6 * tri[:, :, None] + np.arange(6)).reshape(len(tri), 18)
    out = np.zeros((6 * len(X), 6 * len(X)))
    for e in range(len(tri)):
        out[np.ix_(dofs[e], dofs[e])] += K[e]
    return out


@pytest.mark.parametrize("kind", KINDS)
def test_membrane_patch_test(kind):
    """A linear in-plane field (constant strain, with its rotation as the
    drilling DOF) is reproduced exactly inside an irregular tilted patch, by
    each membrane."""
    def field(x, y):
        u, v = 1e-3 * (1 + 2 * x - 0.5 * y), 1e-3 * (-1 + 0.7 * x + 1.5 * y)
        return np.array([u, v, 0, 0, 0, 0.5e-3 * (0.7 + 0.5)])
    got, exact = solve_patch(field, kind)
    assert np.abs(got - exact).max() < 1e-10 * np.abs(exact).max()


def test_bending_patch_test():
    """A constant-curvature deflection w = (kx x^2 + ky y^2 + kxy x y) / 2, with
    its slopes as rotations (theta_x = dw/dy, theta_y = -dw/dx), is reproduced
    exactly inside the tilted patch."""
    kx, ky, kxy = 2e-3, -1e-3, 1.5e-3

    def field(x, y):
        wx, wy = kx * x + 0.5 * kxy * y, ky * y + 0.5 * kxy * x
        return np.array([0, 0, 0.5 * (kx * x * x + ky * y * y + kxy * x * y), wy, -wx, 0])
    got, exact = solve_patch(field)
    assert np.abs(got - exact).max() < 1e-10 * np.abs(exact).max()


def strip(nx, ny, L=1.0, b=0.1):
    xs, ys = np.linspace(0, L, nx + 1), np.linspace(0, b, ny + 1)
    p = np.array([[x, y] for y in ys for x in xs])
    tri = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            tri += [[a, a + 1, a + nx + 2], [a, a + nx + 2, a + nx + 1]]
    return p, np.array(tri)


def cantilever(nx, ny, load):
    """Tip deflection / beam theory of a clamped strip 1 m x 0.1 m x 0.01 m
    (nu = 0), tilted in 3D, under a tip force or moment spread over the tip edge."""
    L, b = 1.0, 0.1
    p, tri = strip(nx, ny, L, b)
    Q = tilted_frame()
    X = np.c_[p, np.zeros(len(p))] @ Q.T
    K = shell.stiffness(X[tri], E, 0.0, T)
    dofs = (6 * tri[:, :, None] + np.arange(6)).reshape(len(tri), 18)
    Kg = np.zeros((6 * len(p), 6 * len(p)))
    for e in range(len(tri)):
        Kg[np.ix_(dofs[e], dofs[e])] += K[e]
    tip = np.flatnonzero(np.isclose(p[:, 0], L))
    w = np.full(tip.size, 1.0)
    w[[0, -1]] = 0.5
    w /= w.sum()
    f = np.zeros(6 * len(p))
    ex, ey, ez = Q.T
    for k, node in enumerate(tip):
        if load == "force":
            f[6 * node:6 * node + 3] = w[k] * ez
        elif load == "moment":
            f[6 * node + 3:6 * node + 6] = -w[k] * ey
        else:
            f[6 * node:6 * node + 3] = w[k] * ey
    free = np.repeat(~np.isclose(p[:, 0], 0.0), 6)
    u = np.zeros(6 * len(p))
    u[free] = np.linalg.solve(Kg[np.ix_(free, free)], f[free])
    along = ey if load == "in-plane" else ez
    deflection = np.mean([u[6 * k:6 * k + 3] @ along for k in tip])
    EI = E * (T * b ** 3 if load == "in-plane" else b * T ** 3) / 12
    beam = {"force": L ** 3 / (3 * EI), "moment": L ** 2 / (2 * EI), "in-plane": L ** 3 / (3 * EI)}
    return deflection / beam[load]


def test_cantilever_strip_against_beam_theory():
    """10 x 1 cells of 2 triangles: tip force and tip moment within 0.1 % of
    Euler-Bernoulli (DKT bending); the in-plane tip force (Allman membrane)
    converges to it from below: 0.65, 0.87, 0.97 on 10 x 1, 20 x 2, 40 x 4."""
    assert cantilever(10, 1, "force") == pytest.approx(1.0, abs=1e-3)
    assert cantilever(10, 1, "moment") == pytest.approx(1.0, abs=1e-6)
    inplane = [cantilever(10 * k, k, "in-plane") for k in (1, 2, 4)]
    assert inplane[0] < inplane[1] < inplane[2] < 1.0 and inplane[2] > 0.95, inplane


def shell_scene(mesh, params, body, constraints, nu=NU, **material):
    return {
        "name": "shell", "time": {"end": 1e-3, "dt": 1e-6},
        "model": {"kind": "continuum", "mesh": str(ROOT / "meshes" / mesh),
                  "mesh_parameters": params, "body": body, "constraints": constraints,
                  "material": {"E": E, "nu": nu, "rho": 7800.0, "kind": "shell", "thickness": T,
                               **material}},
        "partitions": [{"name": "all", "method": "fem", "group": body, "integrator": "explicit",
                        "ratio": 1}],
        "reference": "none",
    }


def frequencies(raw, k):
    """The k lowest natural frequencies [rad/s] of the scene's model (its
    assembled stiffness and lumped masses, fixed DOFs removed)."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import eigsh
    from solver.model import arrays
    from solver.partitions.assembly import triplets
    from solver.model.binding import from_dict
    mdl = arrays.build(from_dict(raw))
    nodes = np.arange(mdl.n_nodes)
    r, c, v = triplets(mdl.stiffness_blocks(nodes), mdl.dofmap)
    n = mdl.dofmap.n_dofs
    K = sp.coo_matrix((v, (r, c)), shape=(n, n)).tocsc()
    m = arrays.dof_masses(mdl, nodes)
    free = np.flatnonzero(~mdl.fixed & (m > 0))
    K = K[free][:, free]
    w2 = eigsh(K, k, sp.diags(m[free]).tocsc(), sigma=-1.0, which="LM")[0]
    return np.sqrt(np.clip(np.sort(w2), 0.0, None))


def test_simply_supported_plate_frequencies_converge():
    """Square plate 1 m x 1 m x 0.01 m, simply supported (edges: ux, uy, uz
    held): the four lowest frequencies against pi^2 (m^2 + n^2) sqrt(D / rho t)
    on n x n meshes of triangles; the error falls about 4x per halving."""
    D = E * T ** 3 / (12 * (1 - NU ** 2))
    exact = np.pi ** 2 * np.array([2, 5, 5, 8]) * np.sqrt(D / (7800 * T))
    errors = []
    for n in (8, 16, 32):
        raw = shell_scene("plate_shell.geo", {"n": n}, "plate",
                          [{"group": "edges", "dofs": ["ux", "uy", "uz"]}])
        errors.append(np.abs(frequencies(raw, 4) / exact - 1).max())
    assert errors[2] < 0.002, errors
    assert errors[0] / errors[1] > 3 and errors[1] / errors[2] > 3, errors


def test_free_ring_in_plane_frequencies_converge():
    """A free ring (radius 1 m, width 0.05 m, wall 0.01 m, nu = 0) held in its
    plane (uz, rx, ry of every node): after three rigid modes, the in-plane
    flexural modes n = 2, 3 against sqrt(EI / rho A R^4) n (n^2 - 1) / sqrt(n^2 + 1)."""
    b = 0.05
    base = np.sqrt(E * T ** 2 / (12 * 7800))
    exact = np.array([base * n * (n * n - 1) / np.sqrt(n * n + 1) for n in (2, 2, 3, 3)])
    errors = []
    for n in (24, 48, 96):
        raw = shell_scene("ring_shell.geo", {"n": n, "b": b}, "ring",
                          [{"group": "ring", "dofs": ["uz", "rx", "ry"]}], nu=0.0)
        w = frequencies(raw, 7)
        assert np.all(w[:3] < 1e-3 * w[3]), w
        errors.append(np.abs(w[3:] / exact - 1).max())
    assert errors[2] < 0.01, errors
    assert errors[0] > errors[1] > errors[2], errors


def test_plate_run_and_its_guard(tmp_path):
    """configs/plate_shell.yaml runs (a struck simply supported plate); a step
    beyond the shell's critical step (bending with physical rotary inertia,
    1.71e-6 s on this mesh) is refused before stepping, naming it; with
    rotary_inertia scaled the membrane sets it (7.76e-6 s)."""
    import h5py
    out = tmp_path / "p.h5"
    proc = run_cli(["configs/plate_shell.yaml", "--set", f"output.file={out}", "--set",
                    "time.end=1.9995e-3"])                      # 1333 steps
    assert proc.returncode == 0, proc.stderr
    with h5py.File(out) as f:
        w = f["probes/centre/displacement"][()]
        assert w.max() > 1e-5 and np.isfinite(w).all()
    line = refused("configs/plate_shell.yaml", ["time.dt=1.8e-6", "time.end=1.8e-3"], tmp_path)
    assert "is unstable, critical step 1.71" in line, line
    proc = run_cli(["configs/plate_shell.yaml", "--set", f"output.file={out}", "--set",
                    "time.end=1.54e-5", "--set", "time.dt=7.7e-6", "--set",
                    "model.material.rotary_inertia=scaled"])
    assert proc.returncode == 0 and "critical step 7.7" in proc.stdout, proc.stdout + proc.stderr


@pytest.mark.parametrize("sets, key", [
    (["model.material.kind=solid"], "model.material.kind"),
    (["model.material.kind=plane_stress", "model.mesh_parameters.tilt=30"], "model.material.kind"),
    (["model.material.thickness=null"], "model.material.thickness"),
    (["model.material.thickness=0"], "model.material.thickness"),
    (["model.constraints.0.dofs=[uy, rw]"], "model.constraints[0].dofs"),
    (["model.material.kind=plane_stress", "model.constraints.0.dofs=[ux, rx]"],
     "model.constraints[0].dofs"),
    (["model.constraints.0.group=nowhere"], "model.constraints[0].group"),
    (["loads.0.direction=[0, 1]", "loads.0.at=null", "loads.0.group=x0"], "loads[0].direction"),
    (["loads.0.at=[3.0, 0.5, 0.0]"], "loads[0].at"),
    (["partitions=[{name: a, method: fem, nodes: [0, 1], integrator: explicit, ratio: 1}, "
      "{name: b, method: fem, nodes: [1, 2], integrator: explicit, ratio: 1}]"],
     "partitions[1].nodes"),
])
def test_bad_shell_input_is_refused(sets, key, tmp_path):
    line = refused("configs/plate_shell.yaml", sets, tmp_path)
    assert f".yaml: {key}: " in line or line.startswith(f"error: {key}: "), line


def test_a_volume_mesh_is_not_a_shell(tmp_path):
    line = refused("configs/wave_bar_3d.yaml", ["model.material.kind=shell",
                                                "model.material.thickness=0.01"], tmp_path)
    assert "model.material.kind: shell does not fit a 3D mesh" in line, line


@pytest.mark.parametrize("n", [1, 2])
def test_implicit_partition_holds_its_fixed_dofs(n, tmp_path):
    """An implicit partition keeps constrained DOFs at zero (their rows and
    columns of K_eff are the identity): the plate's edge stays at u_z = 0 while
    its centre deflects, on 1 rank (LU) and on 2 (CG + GAMG over a partition
    split in two)."""
    import h5py
    out = tmp_path / "p.h5"
    proc = run_cli(["configs/plate_shell.yaml", "--set", f"output.file={out}", "--set",
                    "time.end=2e-3", "--set", "time.dt=1e-5", "--set",
                    "partitions.plate.integrator=implicit", "--set",
                    "probes=[{name: centre, at: [0.5, 0.5, 0.0], component: 2}, "
                    "{name: edge, at: [0.0, 0.5, 0.0], component: 2}]"], n=n if n > 1 else None)
    assert proc.returncode == 0, proc.stderr
    with h5py.File(out) as f:
        assert np.abs(f["probes/centre/displacement"][()]).max() > 1e-5
        assert np.abs(f["probes/edge/displacement"][()]).max() < 1e-14


def test_coarse_u_tube(tmp_path):
    """Ma et al.'s (2018) U-tube, coarse (24 elements around, 20 ms): the conserving
    scheme at m = 12 and the staggered one at m = 3 follow the all-explicit
    run's impact node within 1 % of its peak; energy (kinetic + strain) equals
    the load's work to 1e-6 of it once the load has gone."""
    import h5py
    base = ["--set", "model.mesh_parameters.nc=24", "--set", "time.end=0.019992",   # 833 x 12 x 2e-6
            "--set", "output.energy_every=10"]
    runs = {"explicit": ["--set", "coupling.scheme=overlap", "--set",
                         "partitions=[{name: all, method: fem, group: tube, integrator: explicit, "
                         "beta: 0.0, ratio: 1}]"],
            "conserving": [],
            "staggered": ["--set", "coupling.scheme=staggered", "--set",
                          "partitions.implicit.ratio=3"]}
    out = {}
    for name, sets in runs.items():
        path = tmp_path / f"{name}.h5"
        proc = run_cli(["configs/u_tube.yaml", *base, *sets, "--set", f"output.file={path}"])
        assert proc.returncode == 0, proc.stderr
        with h5py.File(path) as f:
            e = {k: f[f"energy/{k}"][()] for k in ("t", "kinetic", "strain", "external_work")}
            out[name] = (f["probes/impact/t"][()], f["probes/impact/displacement"][()], e)
    t_ref, u_ref, _ = out["explicit"]
    assert np.abs(u_ref).max() > 0.01                 # 17 mm down at 6 ms
    for name in ("conserving", "staggered"):
        t, u, e = out[name]
        assert np.abs(u - np.interp(t, t_ref, u_ref)).max() < 0.01 * np.abs(u_ref).max(), name
        late = e["t"] > 0.011
        balance = e["kinetic"] + e["strain"] - e["external_work"]
        assert np.abs(balance[late]).max() < 1e-6 * e["external_work"].max(), name


def test_a_plane_quadrilateral_mesh_is_a_shell_body_in_3d(tmp_path):
    """wave_bar_fem's quad4 strip read as a shell (MITC4 cells, points in 3D):
    its 2D probe point is refused as such, naming the key."""
    line = refused("configs/wave_bar_fem.yaml", ["model.material.kind=shell",
                                                 "model.material.thickness=0.01",
                                                 "loads.0.direction=[1.0, 0.0, 0.0]"], tmp_path)
    assert "probes[0].at: [0.078, 0.0012]: a point of the 3D mesh needs 3 coordinates" in line, line


def one_and_two_ranks(config, probe, tmp_path, end):
    """Run ``config`` to ``end`` on 1 and 2 ranks: {n: (probe history, energy)}."""
    import h5py
    out = {}
    for n in (1, 2):
        path = tmp_path / f"n{n}.h5"
        proc = run_cli([config, "--set", f"output.file={path}", "--set", f"time.end={end}"],
                       n=n if n > 1 else None)
        assert proc.returncode == 0, proc.stderr
        with h5py.File(path) as f:
            assert f.attrs["ranks"] == n
            out[n] = (f[f"probes/{probe}/displacement"][()],
                      {k: f[f"energy/{k}"][()] for k in ("t", "kinetic", "strain", "external_work")})
    return out


def test_plate_on_two_ranks_is_the_one_rank_run(tmp_path):
    """The struck plate with its one partition split over 2 ranks (6-DOF
    blocks across the cut) gives the 1-rank centre history to 1e-12."""
    out = one_and_two_ranks("configs/plate_shell.yaml", "centre", tmp_path, 3e-3)
    one, two = out[1][0], out[2][0]
    assert np.abs(one).max() > 1e-5
    assert np.abs(one - two).max() <= 1e-12 * np.abs(one).max()


def block_strip(tie=1.0, n=4, nl=20, free=False):
    raw = shell_scene("block_strip.geo", {"n": n, "nl": nl}, "block", [], nu=0.0, tie=tie)
    raw["model"]["material"]["kind"] = "solid"
    del raw["model"]["material"]["thickness"]
    raw["model"]["shells"] = [{"group": "strip", "thickness": T}]
    raw["model"]["fixed"] = [] if free else ["root"]
    raw["partitions"] = [{"name": "all", "method": "fem", "group": "block",
                          "integrator": "explicit", "ratio": 1},
                         {"name": "s", "method": "fem", "group": "strip",
                          "integrator": "explicit", "ratio": 1}]
    return raw


def assembled(raw):
    import scipy.sparse as sp
    from solver.model import arrays
    from solver.partitions.assembly import triplets
    from solver.model.binding import from_dict
    mdl = arrays.build(from_dict(raw))
    r, c, v = triplets(mdl.stiffness_blocks(np.arange(mdl.n_nodes)), mdl.dofmap)
    n = mdl.dofmap.n_dofs
    return mdl, sp.coo_matrix((v, (r, c)), shape=(n, n)).tocsr()


def strip_tip(raw):
    """Tip deflection of the welded strip under a unit tip force / beam theory
    of a strip clamped at the weld (1 m x 0.1 m x 10 mm, nu = 0)."""
    from scipy.sparse.linalg import spsolve
    mdl, K = assembled(raw)
    tip = np.flatnonzero(np.isclose(mdl.points[:, 0], 1.0))
    w = np.full(tip.size, 1.0)
    w[np.argsort(mdl.points[tip, 1])[[0, -1]]] = 0.5
    f = np.zeros(K.shape[0])
    f[6 * tip + 2] = w / w.sum()
    free = np.flatnonzero(~mdl.fixed)
    u = np.zeros(K.shape[0])
    u[free] = spsolve(K[free][:, free].tocsc(), f[free])
    return float(np.mean(u[6 * tip + 2])) / (1.0 / (3 * E * 0.1 * T ** 3 / 12))


def test_shell_welded_to_a_solid():
    """Shells and solids in one model: a strip of shell triangles welded along
    a line to a clamped block of hexahedra.  Its tip deflection is beam
    theory's for a strip clamped at the weld within 1 % (the block's own
    compliance and the tie); without the tie (gamma -> 0) the weld is a hinge
    and the strip swings freely."""
    assert strip_tip(block_strip()) == pytest.approx(1.0, abs=0.01)
    assert strip_tip(block_strip(tie=10.0)) == pytest.approx(1.0, abs=0.003)
    assert strip_tip(block_strip(tie=1e-9)) > 100


def test_shell_and_solid_rigid_modes():
    """The free block with its strip: the six rigid motions (rotations: the
    shell nodes' theta = the rigid rotation; the solid-only nodes' rotations
    are held) cost nothing."""
    mdl, K = assembled(block_strip(free=True))
    X = mdl.points
    for c in range(3):
        for kind in ("translation", "rotation"):
            r = np.zeros((mdl.n_nodes, 6))
            w = np.zeros(3)
            w[c] = 1.0
            if kind == "translation":
                r[:, c] = 1.0
            else:
                r[:, :3] = np.cross(w, X)
                r[:, 3:] = w
            r = r.ravel()
            r[mdl.fixed] = 0.0
            assert np.abs(K @ r).max() < 1e-9 * abs(K).max(), (kind, c)


def test_block_strip_runs(tmp_path):
    """configs/block_strip.yaml runs; energy equals the tip load's work after
    it; on 2 ranks (block and strip each on its own, 6-DOF externals
    exchanged) the tip history is the 1-rank one to 1e-12."""
    out = one_and_two_ranks("configs/block_strip.yaml", "tip", tmp_path, 4e-3)
    for _, e in out.values():
        late = e["t"] > 1.5e-3
        balance = e["kinetic"][late] + e["strain"][late] - e["external_work"][late]
        assert np.abs(balance).max() < 1e-3 * e["external_work"].max()
    one, two = out[1][0], out[2][0]
    assert np.abs(one).max() > 1e-4
    assert np.abs(one - two).max() <= 1e-12 * np.abs(one).max()


@pytest.mark.parametrize("sets, key", [
    (["model.material.kind=plane_stress"], "model.shells"),
    (["model.shells.0.group=block"], "model.shells[0].group"),
    (["model.shells.0.thickness=0"], "model.shells[0].thickness"),
])
def test_bad_shells_on_solids(sets, key, tmp_path):
    line = refused("configs/block_strip.yaml", sets, tmp_path)
    assert f".yaml: {key}: " in line, line


def test_stress_resultants_of_exact_fields():
    """On triangles tilted in 3D, a uniform membrane strain gives N = t D eps
    and a constant curvature M = t^3/12 D kappa in the element's frame; von
    Mises of a pure uniaxial N is N / t."""
    rng = np.random.default_rng(5)
    Q = tilted_frame()
    p = rng.uniform(0, 1, (20, 3, 2))
    X = np.concatenate([p, np.zeros((20, 3, 1))], axis=2) @ Q.T
    Dm = E / (1 - NU ** 2) * np.array([[1, NU, 0], [NU, 1, 0], [0, 0, (1 - NU) / 2]])
    R, x, _ = shell.frames(X)
    eps, kap = np.array([1e-3, -4e-4, 6e-4]), np.array([2e-2, -1e-2, 3e-2])

    def dofs(field):
        """Element DOFs (global axes) of a field given in each element's frame."""
        u = np.zeros((20, 3, 6))
        for e in range(20):
            for a in range(3):
                loc = field(*x[e, a])
                u[e, a, :3] = R[e].T @ loc[:3]
                u[e, a, 3:] = R[e].T @ loc[3:]
        return u.reshape(20, 18)

    def stretch(px, py):
        u, v = eps[0] * px + 0.5 * eps[2] * py, eps[1] * py + 0.5 * eps[2] * px
        return np.array([u, v, 0, 0, 0, 0.0])

    def bend(px, py):
        wx, wy = kap[0] * px + 0.5 * kap[2] * py, kap[1] * py + 0.5 * kap[2] * px
        return np.array([0, 0, 0.5 * (kap[0] * px * px + kap[1] * py * py + kap[2] * px * py),
                         wy, -wx, 0])
    N, M, _ = shell.resultants(X, dofs(stretch), E, NU, T)
    assert np.allclose(N, T * Dm @ eps, rtol=1e-9) and np.abs(M).max() < 1e-6 * np.abs(N).max()
    N, M, _ = shell.resultants(X, dofs(bend), E, NU, T)
    assert np.allclose(M, T ** 3 / 12 * Dm @ kap, rtol=1e-9)
    eps = np.array([1e-3, -NU * 1e-3, 0.0])                  # uniaxial stress
    _, _, mises = shell.resultants(X, dofs(stretch), E, NU, T)
    assert np.allclose(mises, E * 1e-3, rtol=1e-9)


def test_shell_fields(tmp_path):
    """XDMF fields of shells: displacement, rotation, and per triangle the
    membrane forces, moments and von Mises stress (NaN on the block's
    hexahedra in a model with both)."""
    from meshio.xdmf import TimeSeriesReader
    for config in ("plate_shell", "block_strip"):
        out = tmp_path / f"{config}.h5"
        proc = run_cli([f"configs/{config}.yaml", "--set", f"output.file={out}", "--set",
                        "time.end=1.8e-3", "--set", "output.fields={every: 400}"])
        assert proc.returncode == 0, proc.stderr
        mesh = TimeSeriesReader(str(tmp_path / f"{config}_fields.xdmf"))
        points, cells = mesh.read_points_cells()
        assert points.shape[1] == 3 and mesh.num_steps >= 2
        _, pd, cd = mesh.read_data(mesh.num_steps - 1)
        assert {"displacement", "velocity", "rotation"} <= set(pd)
        assert np.abs(pd["rotation"]).max() > 0
        for block, mises in zip(cells, cd["von_mises"]):
            if block.type == "triangle":
                assert np.isfinite(mises).all() and mises.max() > 1e5
            else:
                assert np.isnan(mises).all()
