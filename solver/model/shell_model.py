"""Shell models: a gmsh surface in 3D meshed with triangles, quadrilaterals or
both (``model.material.kind: shell``).

Every node has 6 DOFs (u_x, u_y, u_z, theta_x, theta_y, theta_z; index
``node * 6 + c``).  The body's triangles are flat shell triangles
(:mod:`solver.model.shell`), its quadrilaterals MITC4 shells
(:mod:`solver.model.shell_quad`); node masses are the lumped translational
masses and ``inertia`` the lumped rotary inertia of each node's rotations.
Edge groups (line2) carry line loads [N/m], surface groups (tri3 or quad4,
e.g. a loaded patch of the body) pressure-like loads [N/m^2], both along
``direction``;
``model.fixed`` groups fix all six DOFs and ``model.constraints`` chosen ones
(symmetry edges).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from solver.errors import SceneError
from solver.model import shell, shell_quad
from solver.model.boundary import fixed_dofs, load_list
from solver.model.elements import QUAD4, TRI3, Family, elastic, volumes
from solver.model.interface import Shells

# the flat shell triangle: a tri3 of the mesh whose nodes also rotate; not a
# mesh family of its own (its cells are read as tri3), so not registered
SHELL3 = Family("shell3", 2, 3, TRI3.points, TRI3.weights, TRI3.basis, gmsh=TRI3.gmsh,
                meshio=TRI3.meshio, xdmf=TRI3.xdmf, facet=TRI3.facet, simplex=True,
                centre=TRI3.centre, mirror=TRI3.mirror, lumping="row_sum_rotary",
                rotations=True, mesh_cells=TRI3.name)
# the MITC4 quadrilateral: a quad4 of the mesh whose nodes rotate (likewise)
SHELL4 = Family("shell4", 2, 4, QUAD4.points, QUAD4.weights, QUAD4.basis, gmsh=QUAD4.gmsh,
                meshio=QUAD4.meshio, xdmf=QUAD4.xdmf, facet=QUAD4.facet, centre=QUAD4.centre,
                corners=QUAD4.corners, mirror=QUAD4.mirror, lumping="row_sum_rotary",
                rotations=True, mesh_cells=QUAD4.name)
SHELLS = (SHELL3, SHELL4)
DOF_NAMES = ("ux", "uy", "uz", "rx", "ry", "rz")


class ShellStiffness:
    """K_e of shell triangles or quadrilaterals (by the cells' node count),
    computed when asked (like :class:`solver.model.cell_blocks.CellStiffness`)."""

    def __init__(self, points, conn, material):
        self.points, self.conn, self.material = points, conn, material

    @property
    def family(self) -> Family:
        """SHELL3 or SHELL4 by the cells' node count (never stored: a pickled
        copy on another rank must answer with this module's objects)."""
        return SHELL4 if self.conn.shape[1] == 4 else SHELL3

    def __len__(self) -> int:
        return len(self.conn)

    def __getitem__(self, idx) -> np.ndarray:
        m, X = self.material, self.points[self.conn[idx]]
        if self.family is SHELL4:
            return shell_quad.stiffness(X, m.E, m.nu, m.thickness, m.drilling)
        return shell.stiffness(X, m.E, m.nu, m.thickness, m.drilling, m.membrane)

    def lumped_mass(self, idx, rho, rotary) -> np.ndarray:
        """Nodal masses per element node and DOF [e, k, 6] of cells ``idx``."""
        kernel = shell_quad if self.family is SHELL4 else shell
        return kernel.lumped_mass(self.points[self.conn[idx]], rho, self.material.thickness,
                                  rotary)

    def resultants(self, u):
        """Membrane forces, moments and von Mises at the centres (element
        frames) from the cells' DOFs u [e, 6 k]."""
        m, X = self.material, self.points[self.conn]
        if self.family is SHELL4:
            return shell_quad.resultants(X, u, m.E, m.nu, m.thickness)
        return shell.resultants(X, u, m.E, m.nu, m.thickness, m.membrane)

    def subset(self, mask) -> "ShellStiffness":
        return ShellStiffness(self.points, self.conn[mask], self.material)


def shell_cells(mesh, name, where):
    """[(family, conn, gmsh tags)] of group ``name``'s triangles and
    quadrilaterals; other cells refused."""
    group = mesh.group(name, where)
    kinds = {f.mesh_cells for f in SHELLS}
    other = sorted(set(group.cells) - kinds)
    if other:
        raise SceneError(f"{where}: group {name!r} has {', '.join(other)} cells; shell elements "
                         "are 3-node triangles and 4-node quadrilaterals (mesh the surface "
                         "with them)")
    out = [(f, group.cells[f.mesh_cells], group.cell_tags[f.mesh_cells]) for f in SHELLS
           if f.mesh_cells in group.cells]
    if not out:
        raise SceneError(f"{where}: group {name!r} has no triangles or quadrilaterals (a shell "
                         "body is a surface)")
    return out


def shell_nodes(mesh, name) -> np.ndarray:
    """The node ids of group ``name``'s shell cells (triangles and quadrilaterals)."""
    cells = mesh.group(name).cells
    return np.unique(np.concatenate([cells[f.mesh_cells].ravel() for f in SHELLS
                                     if f.mesh_cells in cells] or [np.zeros(0, np.int64)]))


def elements(cells, membrane) -> str:
    """The log's words for the shell cells built: '256 triangles (DKT
    bending, allman membrane), 128 quadrilaterals (MITC4)', and their walls
    where they differ."""
    words = (f"triangles (DKT bending, {membrane} membrane)", "quadrilaterals (MITC4)")
    count = [sum(len(conn) for fam, conn, _ in cells if fam is f) for f in SHELLS]
    text = ", ".join(f"{c} {w}" for c, w in zip(count, words) if c)
    walls = {}
    for fam, conn, Ke in cells:
        if fam.rotations:
            walls[Ke.material.thickness] = walls.get(Ke.material.thickness, 0) + len(conn)
    if len(walls) > 1:
        text += "; walls " + ", ".join(f"{t:g} m on {k} cells" for t, k in walls.items())
    return text


def surface(mesh, group, where, material, wall, sections=()):
    """The shell cells of ``group`` (wall: E, nu, thickness, drilling,
    membrane), one (family, conn, ShellStiffness) per kind and wall, and their
    nodal translational masses and rotary inertias [n_nodes].  ``sections``:
    (group, key, wall) whose cells (of ``group`` too) take that wall."""
    pts, n = mesh.points, len(mesh.points)
    cells = []
    mass, inertia = np.zeros(n), np.zeros(n)
    body = shell_cells(mesh, group, where)
    which = [np.full(len(conn), -1) for _, conn, _ in body]
    for i, (name, key, _) in enumerate(sections):
        hits = 0
        own = shell_cells(mesh, name, key)
        for (family, _, tags), w in zip(body, which):
            sec = next((t for f, _, t in own if f is family), None)
            inside = np.isin(tags, sec) if sec is not None else np.zeros(len(tags), bool)
            if (w[inside] >= 0).any():
                j = int(w[inside][w[inside] >= 0][0])
                cell = int(tags[inside & (w >= 0)][0])
                raise SceneError(f"{key}: gmsh element {cell} is in group {name!r} and in "
                                 f"{sections[j][1]} ({sections[j][0]!r}); give each cell one "
                                 "thickness")
            w[inside] = i
            hits += int(inside.sum())
        size = sum(len(t) for _, _, t in own)
        if hits < size:
            raise SceneError(f"{key}: group {name!r} has {size - hits} of its {size} cells outside "
                             f"the shell body {group!r}")
    for (family, conn, tags), w in zip(body, which):
        for i, wall_i in [(-1, wall)] + [(i, sec[2]) for i, sec in enumerate(sections)]:
            mine = w == i
            if not mine.any():
                continue
            Ke = ShellStiffness(pts, conn[mine], wall_i)
            try:
                if family is SHELL4:
                    shell_quad.check(pts[conn[mine]])
                me = Ke.lumped_mass(slice(None), material.rho, material.rotary_inertia)
            except (shell.BadShell, shell_quad.BadQuad) as e:
                raise SceneError(f"{where}: group {group!r}: gmsh element "
                                 f"{int(tags[mine][e.index])} ({family.mesh_cells}) "
                                 f"{str(e).split(' is ', 1)[1]}") from None
            c = conn[mine]
            mass += np.bincount(c.ravel(), weights=me[:, :, 0].ravel(), minlength=n)
            inertia += np.bincount(c.ravel(), weights=me[:, :, 3].ravel(), minlength=n)
            cells.append((family, c, Ke))
    return cells, mass, inertia


def build(scene, mesh):
    """The shell model of ``scene`` on ``mesh`` (3D points): the fields of its
    :class:`~solver.model.continuum.ContinuumArrays`."""
    spec = scene.model
    m = spec.material
    sections = [(sec.group, f"model.sections[{i}].group", replace(m, thickness=sec.thickness))
                for i, sec in enumerate(spec.sections)]
    cells, mass, inertia = surface(mesh, spec.body, "model.body", m, m, sections)
    pts, n = mesh.points, len(mesh.points)
    fixed = fixed_dofs(scene, mesh, n, 6)
    loads = load_list(scene, mesh, 6, 3)
    return dict(dof=6, points=pts, mass=mass, cells=cells, fixed=fixed, loads=tuple(loads),
                u0=np.zeros(6 * n), v0=np.zeros(6 * n),
                shells=Shells(inertia=inertia, elements=elements(cells, spec.material.membrane)))


# ------------------------------------------------------------ shells and solids
@dataclass(frozen=True)
class Wall:
    """A shell surface's elastic data (the body's material, its thickness)."""
    E: float
    nu: float
    thickness: float
    drilling: float
    membrane: str = "allman"


class Padded:
    """A family's K_e on nodes with more DOFs: the translations' blocks, zero
    for the rest ([e, small k, small k] -> [e, big k, big k]; solids on shell
    nodes 3 -> 6, plane cells on the nodes of rotating particles 2 -> 3)."""

    def __init__(self, Ke, k, small: int = 3, big: int = 6):
        self.Ke, self.k, self.small, self.big = Ke, k, small, big

    def __len__(self) -> int:
        return len(self.Ke)

    def __getitem__(self, idx) -> np.ndarray:
        small = self.Ke[idx]
        k, s, b = self.k, self.small, self.big
        out = np.zeros((small.shape[0], k, b, k, b))
        out[:, :, :s, :, :s] = small.reshape(-1, k, s, k, s)
        return out.reshape(-1, b * k, b * k)

    def subset(self, mask) -> "Padded":
        return Padded(self.Ke.subset(mask), self.k, self.small, self.big)


class Tie:
    """Ties a shell node's rotation to the solid around it: for each (solid
    element, its node a on a shell) a penalty gamma V / k |theta_a - omega|^2,
    omega = curl(u) / 2 of the element at its centroid and gamma = ``tie`` G.
    A rigid motion costs nothing; without it a shell edge on a solid face
    would be a hinge (a solid has no rotational stiffness)."""

    def __init__(self, family, points, conn, node, weight):
        self.family, self.points, self.conn, self.node, self.weight = (family, points, conn,
                                                                       node, weight)

    def __len__(self) -> int:
        return len(self.conn)

    def __getitem__(self, idx) -> np.ndarray:
        conn, node, w = self.conn[idx], self.node[idx], self.weight[idx]
        g = centroid_gradients(self.family, self.points[conn])          # [p, k, 3]
        p, k = conn.shape
        D = np.zeros((p, 3, k, 6))
        gx, gy, gz = g[..., 0], g[..., 1], g[..., 2]
        # omega = sum_b W_b u_b, W_b = 1/2 [[0, -gz, gy], [gz, 0, -gx], [-gy, gx, 0]]
        D[:, 0, :, 1], D[:, 0, :, 2] = 0.5 * gz, -0.5 * gy
        D[:, 1, :, 0], D[:, 1, :, 2] = -0.5 * gz, 0.5 * gx
        D[:, 2, :, 0], D[:, 2, :, 1] = 0.5 * gy, -0.5 * gx
        rows = np.arange(p)
        for c in range(3):
            D[rows, c, node, 3 + c] += 1.0
        D = D.reshape(p, 3, 6 * k)
        return w[:, None, None] * np.einsum("pci,pcj->pij", D, D)

    def subset(self, mask) -> "Tie":
        return Tie(self.family, self.points, self.conn[mask], self.node[mask], self.weight[mask])


def centroid_gradients(family, X):
    """dN_a/dx at the element's centroid [e, k, 3] (solid families)."""
    _, dN = family.shape(np.array([family.centre]))
    J = np.einsum("ai,eaj->eij", dN[0], X)
    return np.einsum("eij,aj->eai", np.linalg.inv(J), dN[0])


def build_mixed(scene, mesh, solid_cells, mass):
    """A solid body with shell surfaces (``model.shells``): every node has 6
    DOFs; the solid-only nodes' rotations are fixed; shell nodes on the solid
    are tied to it.  The fields of its :class:`~solver.model.continuum.ContinuumArrays`."""
    spec, mat = scene.model, scene.model.material
    pts, n = mesh.points, len(mesh.points)
    mass = mass.copy()
    inertia = np.zeros(n)
    on_shell = np.zeros(n, bool)
    cells = [(fam, conn, Padded(Ke, fam.n_nodes)) for fam, conn, Ke in solid_cells]
    for i, part in enumerate(spec.shells):
        walls, m, rot = surface(mesh, part.group, f"model.shells[{i}].group", mat,
                                Wall(mat.E, mat.nu, part.thickness, mat.drilling,
                                     mat.membrane))
        mass += m
        inertia += rot
        for cell in walls:
            on_shell[cell[1]] = True
        cells += walls
    G = mat.E / (2 * (1 + mat.nu))
    for fam, conn, _ in solid_cells:
        e, a = np.nonzero(on_shell[conn])
        if e.size:
            weight = mat.tie * G * volumes(fam, pts[conn[e]]) / fam.n_nodes
            cells.append((Family("tie", fam.dim, fam.n_nodes, fam.points, fam.weights),
                          conn[e], Tie(fam, pts, conn[e], a, weight)))
    fixed = fixed_dofs(scene, mesh, n, 6)
    still = ~on_shell
    fixed.reshape(n, 6)[still, 3:] = True                 # solid-only nodes do not rotate
    inertia[still] = np.maximum(mass[still], 1.0)          # (never used: those DOFs are fixed)
    loads = load_list(scene, mesh, 6, 3)
    return dict(dof=6, points=pts, mass=mass, cells=cells, fixed=fixed, loads=tuple(loads),
                u0=np.zeros(6 * n), v0=np.zeros(6 * n), material_D=elastic(mat).D(),
                shells=Shells(inertia=inertia, elements=elements(cells, mat.membrane)))
