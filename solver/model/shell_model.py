"""Shell models: a gmsh surface in 3D meshed with triangles (``model.material.kind:
shell``).

Every node has 6 DOFs (u_x, u_y, u_z, theta_x, theta_y, theta_z; index
``node * 6 + c``).  The body's triangles are flat shell elements
(:mod:`solver.model.shell`); node masses are the lumped translational masses
and ``inertia`` the lumped rotary inertia of each node's rotations.  Edge
groups (line2) carry line loads [N/m], surface groups (tri3, e.g. a loaded
patch of the body) pressure-like loads [N/m^2], both along ``direction``;
``model.fixed`` groups fix all six DOFs and ``model.constraints`` chosen ones
(symmetry edges).
"""
from __future__ import annotations

import numpy as np

from solver.errors import SceneError
from solver.model import shell
from solver.model.elements import Family

SHELL3 = Family("shell3", 2, 3, np.array([[1 / 3, 1 / 3]]), np.array([0.5]))
DOF_NAMES = ("ux", "uy", "uz", "rx", "ry", "rz")


class ShellStiffness:
    """K_e of shell triangles, computed when asked (like
    :class:`solver.partitions.assembly.CellStiffness`)."""

    def __init__(self, points, conn, material):
        self.points, self.conn, self.material = points, conn, material

    def __len__(self) -> int:
        return len(self.conn)

    def __getitem__(self, idx) -> np.ndarray:
        m = self.material
        return shell.stiffness(self.points[self.conn[idx]], m.E, m.nu, m.thickness, m.drilling)

    def subset(self, mask) -> "ShellStiffness":
        return ShellStiffness(self.points, self.conn[mask], self.material)


def triangles(mesh, name, where):
    """The tri3 connectivity of group ``name``; other cells refused."""
    group = mesh.group(name, where)
    other = sorted(set(group.cells) - {"tri3"})
    if other:
        raise SceneError(f"{where}: group {name!r} has {', '.join(other)} cells; shell elements "
                         "are 3-node triangles (mesh the surface with triangles)")
    if "tri3" not in group.cells:
        raise SceneError(f"{where}: group {name!r} has no triangles (a shell body is a surface)")
    return group.cells["tri3"], group.cell_tags["tri3"]


def build(scene, mesh):
    """The shell model of ``scene`` on ``mesh`` (3D points)."""
    from solver.model.continuum import ContinuumArrays, facet_forces, fixed_dofs, load_list
    spec = scene.model
    mat = spec.material
    conn, tags = triangles(mesh, spec.body, "model.body")
    pts = mesh.points
    try:
        me = shell.lumped_mass(pts[conn], mat.rho, mat.thickness, mat.rotary_inertia)
    except shell.BadShell as e:
        raise SceneError(f"model.body: group {spec.body!r}: gmsh element {int(tags[e.index])} "
                         f"(tri3) {str(e).split(' is ', 1)[1]}") from None
    n = len(pts)
    mass = np.bincount(conn.ravel(), weights=me[:, :, 0].ravel(), minlength=n)
    inertia = np.bincount(conn.ravel(), weights=me[:, :, 3].ravel(), minlength=n)
    cells = [(SHELL3, conn, ShellStiffness(pts, conn, mat))]
    fixed = fixed_dofs(scene, mesh, n, 6)
    loads = load_list(scene, mesh, 6, 3, facet_forces)
    return ContinuumArrays(6, pts, mass, cells, fixed, tuple(loads), np.zeros(6 * n),
                           np.zeros(6 * n), inertia=inertia)
