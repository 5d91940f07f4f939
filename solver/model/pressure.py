"""Pressure loads (``loads[].pressure: true``): a pressure p on a group's
facets pushes against each facet's normal, the nodal force of node a being
-p times the integral of N_a n dA (the area vector the node's shape function
weighs).

The normal of a facet on a body cell (an edge of a 2D body, a face of a 3D
one) points out of that cell, so a positive pressure pushes into the body
(a shell skin on a solid's face too); a facet on no body cell must be a
shell cell (triangle or quadrilateral of the shell body or of model.shells),
whose normal follows its node order (the right-hand rule), as the shell
element's frame does.  A facet inside the body (on two of its cells) or on
no cell of the model is refused.  The normal is the reference one: the models are
geometrically linear (small displacements and rotations), so the load does
not turn with the surface.
"""
from __future__ import annotations

import numpy as np

from solver.model.elements import CELLS
from solver.scene.schema import fail

GAUSS2 = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float) / np.sqrt(3.0)


def area_vectors(family, X) -> np.ndarray:
    """v_ea = integral of N_a n dA over each facet [e, k, space] (X [e, k,
    space]): for an edge of a 2D body the length share of its right-hand
    normal (t_y, -t_x), for a face the node's share of its area vector by its
    node order (exact for triangles; 2 x 2 Gauss over a quadrilateral's
    bilinear map, so a warped one is integrated too)."""
    if family.dim == 1:
        t = X[:, 1] - X[:, 0]
        n = np.stack([t[:, 1], -t[:, 0]], axis=1)
        return np.repeat(0.5 * n[:, None, :], 2, axis=1)
    if family.simplex:
        n = 0.5 * np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
        return np.repeat(n[:, None, :] / 3, 3, axis=1)
    N, dN = family.shape(GAUSS2)                                  # [q, a], [q, a, 2]
    T = np.einsum("qai,eaj->eqij", dN, X)
    return np.einsum("eqx,qa->eax", np.cross(T[:, :, 0], T[:, :, 1]), N)


def outward(facets, normal, centre, body):
    """(sign, count) per facet [f]: ``count`` the body cells it lies on, and
    ``sign`` +1 where its ``normal`` points out of the first of them, -1
    where into it, 0 on none.  facets [f, k] node ids, centre [f, space]
    their centroids; ``body``: [(conn, cell centroids)] of the body's cell
    blocks."""
    sign = np.zeros(len(facets), dtype=np.int8)
    count = np.zeros(len(facets), dtype=np.int64)
    first = facets[:, 0]
    for conn, cc in body:
        k = conn.shape[1]
        flat = conn.ravel()
        order = np.argsort(flat, kind="stable")
        per_node = np.bincount(flat, minlength=int(max(flat.max(), first.max())) + 1)
        ptr = np.concatenate([[0], np.cumsum(per_node)])
        degree = per_node[first]
        for j in range(int(degree.max()) if degree.size else 0):
            f = np.flatnonzero(degree > j)
            cell = order[ptr[first[f]] + j] // k
            on = (conn[cell][:, :, None] == facets[f][:, None, :]).any(axis=1).all(axis=1)
            f, cell = f[on], cell[on]
            count[f] += 1
            new = sign[f] == 0
            side = np.einsum("fx,fx->f", normal[f[new]], centre[f[new]] - cc[cell[new]])
            sign[f[new]] = np.where(side > 0, 1, -1)
    return sign, count


def nodal_vectors(mesh, group_name, where, body_name, space, shell_groups=()) -> np.ndarray:
    """sum over the group's facets of v_ea, each facet's normal turned out of
    the body cell it lies on: [n_nodes, space].  A facet on no body cell
    keeps its node order's normal where it is a cell of ``shell_groups``
    (the shell body, model.shells); one on no cell of either, or inside the
    body (on two of its cells), is refused."""
    group = mesh.group(group_name, where)
    body = []
    for name, conn in mesh.group(body_name).cells.items():
        family = CELLS.get(name)
        if family is not None and family.dim == space:
            body.append((conn, mesh.points[conn].mean(axis=1)))
    out = np.zeros((len(mesh.points), space))
    for name, conn in group.cells.items():
        family = CELLS[name]
        tags = group.cell_tags[name]
        X = mesh.points[conn][:, :, :space]
        v = area_vectors(family, X)
        sign, count = outward(conn, v.sum(axis=1), X.mean(axis=1), body)
        shell = np.zeros(len(conn), bool)
        for g in shell_groups:
            cells = mesh.group(g).cell_tags
            if name in cells:
                shell |= np.isin(tags, cells[name])
        for bad, words in ((count > 1, "lies inside the body (on two of its cells): a pressure "
                                       "acts on its boundary"),
                           ((count == 0) & ~shell, "lies on no cell of the body nor of a shell "
                                                   "surface: nothing would carry it")):
            if bad.any():
                fail(where, f"gmsh element {int(tags[np.argmax(bad)])} ({name}) of group "
                     f"{group_name!r} {words}")
        v *= np.where(sign == 0, 1, sign)[:, None, None]
        for a in range(conn.shape[1]):
            np.add.at(out, conn[:, a], v[:, a])
    return out
