"""What set-up prints so that a unit slip shows at once (as LS-DYNA's d3hsp does).

The model's total mass, the wave speeds of its materials, and for every
partition the few elements with the smallest *estimated* stable steps:

- a continuum cell: L / c, L its characteristic length (triangles and
  tetrahedra: the smallest altitude, 2A / longest edge and 3V / largest face;
  quadrilaterals: A / the longest side; hexahedra: V / the largest face, as
  LS-DYNA's defaults) and c the p-wave speed sqrt((lambda + 2 mu) / rho) (plane stress and
  shells: the plate speed sqrt(E / (rho (1 - nu^2))));
- a bond or spring: 2 sqrt(m* / k), the critical step of the spring alone
  between its two masses (m* = m_i m_j / (m_i + m_j); the mass of a spring to
  the ground or to a fixed node).

These are per-element estimates, for reading: the step the guard checks is
2 / omega_max of the partition's assembled operator
(:mod:`solver.partitions.stability`), printed beside them.  A density of 2.7
instead of 2700 moves the wave speeds by sqrt(1000) and the total mass by 1000.
Numpy only, on the whole model (rank 0).
"""
from __future__ import annotations

import math

import numpy as np

from solver.model import initial, layout as overlap, prescribed

SHOWN = 3                # elements listed per partition
CHUNK = 32768            # cells measured at a time (bounds the temporaries)


def speeds(material) -> dict:
    """Wave speeds [m/s] of a ``model.material`` section: p and s (continua;
    p is the plate speed in plane stress), plate and s (shells), bar sqrt(E/rho)."""
    E, nu, rho = material.E, material.nu, material.rho
    mu = E / (2 * (1 + nu))
    bar = math.sqrt(E / rho)
    if material.kind in ("plane_stress", "shell"):
        p = math.sqrt(E / (rho * (1 - nu ** 2)))
    else:
        lam = E * nu / ((1 + nu) * (1 - 2 * nu))
        p = math.sqrt((lam + 2 * mu) / rho)
    return {"p": p, "s": math.sqrt(mu / rho), "bar": bar}


def describe_materials(scene) -> str:
    """The material line: E, nu, rho and the wave speeds (networks: None)."""
    spec = scene.model
    if spec.kind != "continuum":
        return None
    m = spec.material
    c = speeds(m)
    p = "plate" if m.kind in ("plane_stress", "shell") else "p wave"
    text = (f"material {m.kind}: E {m.E:.4g} Pa, nu {m.nu:g}, rho {m.rho:.4g} kg/m^3; wave speeds "
            f"{p} {c['p']:.5g} m/s, s wave {c['s']:.5g} m/s, bar sqrt(E/rho) {c['bar']:.5g} m/s")
    if spec.shells:
        text += (f"; its shells: plate sqrt(E/(rho (1 - nu^2))) "
                 f"{math.sqrt(m.E / (m.rho * (1 - m.nu ** 2))):.5g} m/s")
    lat = spec.lattice
    if lat is not None:
        E = lat.E or m.E
        text += f"; lattice bonds: bar sqrt(E/rho) {math.sqrt(E / m.rho):.5g} m/s" + (
            f" (lattice E {E:.4g} Pa)" if lat.E else "")
    return text


def total_mass(mdl) -> float:
    """Sum of the model's lumped (translational) node masses [kg]."""
    return float(np.sum(mdl.mass))


def _length(family, X: np.ndarray) -> np.ndarray:
    """Characteristic lengths [e] of cells of ``family`` (asked its dimension and
    simplex flag) with corner coordinates X [e, a, d]; None for other cells."""
    def norm(v):
        return np.linalg.norm(v, axis=-1)

    def area(a, b):                                   # |a x b| / 2, in 2D or 3D
        if a.shape[-1] == 2:
            return 0.5 * np.abs(a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0])
        return 0.5 * norm(np.cross(a, b))
    shape = (family.dim, family.simplex, family.n_nodes)
    if shape == (2, True, 3):                         # triangles (tri3, shell3)
        edges = np.stack([norm(X[:, 1] - X[:, 0]), norm(X[:, 2] - X[:, 1]),
                          norm(X[:, 0] - X[:, 2])], axis=1)
        return 2 * area(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]) / edges.max(axis=1)
    if shape == (2, False, 4):                        # quadrilaterals (quad4, shell4)
        d1, d2 = X[:, 2] - X[:, 0], X[:, 3] - X[:, 1]
        sides = np.stack([norm(X[:, (i + 1) % 4] - X[:, i]) for i in range(4)], axis=1)
        return area(d1, d2) / sides.max(axis=1)
    if shape == (3, True, 4):                         # tetrahedra
        vol = np.abs(np.einsum("ei,ei->e", X[:, 1] - X[:, 0],
                               np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]))) / 6
        faces = [(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)]
        big = np.max(np.stack([area(X[:, b] - X[:, a], X[:, c] - X[:, a]) for a, b, c in faces],
                              axis=1), axis=1)
        return 3 * vol / big
    if shape == (3, False, 8):                        # hexahedra
        # volume from the Jacobian at the centre (exact for parallelepipeds), faces
        # as half the cross product of their diagonals (gmsh's node order)
        a = 0.25 * ((X[:, 1] + X[:, 2] + X[:, 5] + X[:, 6]) - (X[:, 0] + X[:, 3] + X[:, 4] + X[:, 7]))
        b = 0.25 * ((X[:, 2] + X[:, 3] + X[:, 6] + X[:, 7]) - (X[:, 0] + X[:, 1] + X[:, 4] + X[:, 5]))
        c = 0.25 * ((X[:, 4] + X[:, 5] + X[:, 6] + X[:, 7]) - (X[:, 0] + X[:, 1] + X[:, 2] + X[:, 3]))
        vol = np.abs(np.einsum("ei,ei->e", a, np.cross(b, c)))
        faces = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
        big = np.max(np.stack([area(X[:, r] - X[:, p], X[:, s] - X[:, q]) for p, q, r, s in faces],
                              axis=1), axis=1)
        return vol / big
    return None


def _family(Ke):
    """The cell Family of a block set's stiffness (mesh cells, shells, solid
    cells padded to 6 DOFs), or None for other elements (bonds, ties)."""
    kind = type(Ke).__name__
    if kind == "Padded":                             # shells on solids: the solid cells
        Ke, kind = Ke.Ke, type(Ke.Ke).__name__
    if kind == "ShellStiffness":
        return Ke.family
    if kind == "CellStiffness":
        return Ke.family
    return None


def _node_masses(mdl) -> np.ndarray:
    """Node masses, infinite for nodes whose every DOF is fixed."""
    m = np.asarray(mdl.mass, dtype=float).copy()
    fixed = np.asarray(mdl.fixed)
    if fixed.any():
        counts = mdl.dofmap.counts
        node = np.repeat(np.arange(counts.size), counts)
        held = np.bincount(node, weights=fixed, minlength=counts.size)
        m[(held == counts) & (counts > 0)] = np.inf
    return m


def _spring_steps(conn, k, mass):
    """2 sqrt(m*/k) of springs ``conn`` [n, 1 or 2] (one column: to the ground)."""
    mi = mass[conn[:, 0]]
    mj = mass[conn[:, 1]] if conn.shape[1] > 1 else np.full(len(conn), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(np.isinf(mi), 0.0, 1.0 / mi) + np.where(np.isinf(mj), 0.0, 1.0 / mj)
        return np.where((inv > 0) & (k > 0), 2.0 / np.sqrt(k * inv), np.inf)


def element_steps(scene, mdl, blocks, keep=None):
    """(steps [n], label(i) -> str) of the cells, bonds and springs of ``blocks``
    (block sets (conn, Ke) in model node ids); ``keep(conn)`` selects rows.
    Measured CHUNK rows at a time, the selected rows never copied out (a
    lattice's 4 M bonds at once were rank 0's set-up peak)."""
    c = speeds(scene.model.material)["p"] if scene.model.kind == "continuum" else None
    plate = (math.sqrt(scene.model.material.E / (scene.model.material.rho *
                                                 (1 - scene.model.material.nu ** 2)))
             if c is not None else None)
    mass = _node_masses(mdl)
    points = mdl.points
    steps, kinds, conns = [], [], []
    for conn, Ke in blocks:
        conn = np.asarray(conn)
        if not len(conn):
            continue
        fam = _family(Ke)
        if fam is not None and c is not None and points is not None:
            if _length(fam, points[conn[:1]]) is None:
                continue
            speed = plate if fam.rotations else c

            def measure(rows, _, fam=fam, speed=speed):
                return _length(fam, points[rows]) / speed
            kind = fam.name
        elif type(Ke).__name__ == "BondStiffness":
            k = np.asarray(Ke.k)

            def measure(rows, at, k=k):
                return _spring_steps(rows, k[at], mass)
            kind = "bond"
        elif isinstance(Ke, np.ndarray) and conn.shape[1] <= 2 and Ke.shape[1:] == (conn.shape[1],) * 2:
            def measure(rows, at, Ke=Ke):
                return _spring_steps(rows, Ke[at, 0, 0], mass)
            kind = "spring"
        else:
            continue                  # carried band bonds, rotation ties: not estimated
        chosen = []                   # the selected row numbers, chunk by chunk
        for s in range(0, len(conn), CHUNK):
            at = np.arange(s, min(s + CHUNK, len(conn)))
            if keep is not None:
                at = at[keep(conn[at])]
            chosen.append(at)
            steps.append(measure(conn[at], at))
        kinds.append(kind)
        conns.append((conn, np.concatenate(chosen)))
    if not steps:
        return np.zeros(0), None
    steps = np.concatenate(steps)
    starts = np.cumsum([0] + [len(at) for _, at in conns])

    def label(i):
        b = int(np.searchsorted(starts, i, side="right")) - 1
        conn, at = conns[b]
        nodes, kind = conn[at[i - starts[b]]], kinds[b]
        if kind in ("bond", "spring"):
            ends = "-".join(str(int(n)) for n in nodes) if len(nodes) > 1 else f"{int(nodes[0])}-ground"
            return f"{kind} {ends}"
        where = ""
        if points is not None:
            centre = points[nodes].mean(axis=0)
            where = " at (" + ", ".join(f"{x:.4g}" for x in centre) + ")"
        return f"{kind} cell (nodes {' '.join(str(int(n)) for n in nodes)}){where}"
    return steps, label


def partition_lines(scene, mdl, owner) -> list[str]:
    """Per partition: its elements with the smallest estimated steps."""
    n = mdl.n_nodes
    everything = np.arange(n)
    out = []
    for p, part in enumerate(scene.partitions):
        blocks = (mdl.bond_blocks(everything) if part.method == "dem" else
                  mdl.stiffness_blocks(everything))
        mine = owner == p

        def keep(conn, mine=mine):
            return mine[conn].any(axis=1)
        steps, label = element_steps(scene, mdl, blocks, keep)
        n_finite = int(np.count_nonzero(np.isfinite(steps)))
        if not n_finite:
            continue
        shown = "; ".join(f"{steps[i]:.4g} s {label(i)}"
                          for i in smallest(steps, min(SHOWN, n_finite)))
        out.append(f"{part.name}: smallest element steps (estimates: L/c per cell, 2 sqrt(m*/k) "
                   f"per bond or spring; {n_finite} elements): {shown}")
    return out


def smallest(values: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` smallest of ``values`` (at least k finite),
    smallest first and ties by index, as a stable argsort of them all would
    give, without one: a lattice's 4 M bonds, often of one step, took three
    index arrays as long as them on rank 0."""
    cut = np.partition(values, k - 1)[k - 1]
    found = [np.flatnonzero(values < cut)]              # fewer than k
    need = k - found[0].size
    for a in range(0, values.size, CHUNK):              # ties at the cut, by index
        if need <= 0:
            break
        hit = np.flatnonzero(values[a:a + CHUNK] == cut)[:need] + a
        found.append(hit)
        need -= hit.size
    cand = np.concatenate(found)
    return cand[np.lexsort((cand, values[cand]))]


def lines(scene, mdl) -> list[str]:
    """The set-up lines: total mass, materials, each partition's smallest steps."""
    out = [f"model: total mass {total_mass(mdl):.6g} kg over {mdl.n_nodes} nodes"]
    mat = describe_materials(scene)
    if mat:
        out.append(mat)
    if mdl.shells is not None:
        out.append(f"shell elements: {mdl.shells.elements}")
    out += initial.describe(mdl) + prescribed.describe(mdl)
    if scene.analysis == "static":
        return out                   # (no step to estimate)
    out += partition_lines(scene, mdl, overlap.owner_map(mdl.n_nodes, scene.partitions))
    return out
