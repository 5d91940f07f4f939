"""What the scene fixes and loads on a mesh: the fixed DOFs of ``model.fixed`` and
``model.constraints``, and the point loads of ``loads`` (a group load as the nodal
forces of its facets).  Used by the continuum and shell models and by the binding.
"""
from __future__ import annotations

import numpy as np

from solver.model import prescribed
from solver.model.elements import CELLS
from solver.model.loads import PointLoad, load_function
from solver.model.pressure import nodal_vectors
from solver.scene.model_spec import DOF_NAMES

_g, _w = np.polynomial.legendre.leggauss(3)
GAUSS3 = np.array([[a, b] for b in _g for a in _g])             # 3x3 Gauss points on [-1, 1]^2
GAUSS3_W = np.array([wa * wb for wb in _w for wa in _w])


def facet_weights(fam, X) -> np.ndarray | None:
    """w_ea = integral of N_a over each facet [n_el, k] (X [n_el, k, space]); None
    for cells that are not facets.  Lines and triangles are exact in closed form
    (length/2, area/3); a quad4 face is integrated with 3x3 Gauss points over
    its bilinear map, |dx/dxi x dx/deta| N_a (exact on a plane face, whatever its
    shape: a trapezoid's nodes do not get area/4 each; close on a warped one)."""
    family = CELLS.get(fam)
    if family is None or family.dim not in (1, 2):
        return None
    if family.dim == 1:
        return np.repeat(0.5 * np.linalg.norm(X[:, 1] - X[:, 0], axis=1)[:, None], 2, axis=1)
    if family.simplex:
        e1, e2 = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
        cross = np.cross(e1, e2) if X.shape[2] == 3 else e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        area = 0.5 * (np.linalg.norm(cross, axis=1) if X.shape[2] == 3 else np.abs(cross))
        return np.repeat(area[:, None] / 3, 3, axis=1)
    N, dN = family.shape(GAUSS3)                                 # [q, a], [q, a, 2]
    T = np.einsum("qai,eaj->eqij", dN, X)                        # tangents dx/dxi_i [e, q, i, x]
    if X.shape[2] == 3:
        dA = np.linalg.norm(np.cross(T[:, :, 0], T[:, :, 1]), axis=2)
    else:
        dA = np.abs(np.linalg.det(T))
    return np.einsum("eq,q,qa->ea", dA, GAUSS3_W, N)


def facet_forces(mesh, group_name, where):
    """Nodal weights w_a = integral of N_a over the group's facets: [n_nodes]."""
    group = mesh.group(group_name, where)
    w = np.zeros(len(mesh.points))
    for fam, conn in group.cells.items():
        we = facet_weights(fam, mesh.points[conn])
        if we is not None:
            w += np.bincount(conn.ravel(), weights=we.ravel(), minlength=len(w))
    return w


def fixed_dofs(scene, mesh, n_nodes, dof):
    """[n_nodes * dof] bool: every DOF of ``model.fixed`` groups, the chosen
    DOFs (ux uy uz rx ry rz) of ``model.constraints`` and those of
    ``model.prescribed`` (held out of the solve, moved as given:
    :mod:`solver.model.prescribed`)."""
    fixed = np.zeros(n_nodes * dof, bool)
    for name in scene.model.fixed:
        nodes = mesh.group(name, "model.fixed").nodes
        fixed[(nodes[:, None] * dof + np.arange(dof)).ravel()] = True
    for i, c in enumerate(scene.model.constraints):
        nodes = mesh.group(c.group, f"model.constraints[{i}].group").nodes
        comps = np.array([DOF_NAMES.index(d) for d in c.dofs])
        fixed[(nodes[:, None] * dof + comps).ravel()] = True
    if scene.model.prescribed:
        fixed |= prescribed.held(scene, mesh, n_nodes, dof, fixed)
    return fixed


def load_list(scene, mesh, dof, space):
    """PointLoads of the scene: group loads as the nodal forces of their facets
    (:func:`facet_forces`) along ``direction`` (``space`` components), node
    loads on DOF ``component`` (``dof`` per node)."""
    loads = []
    for i, load in enumerate(scene.loads):
        g = load_function(load)
        direction = np.asarray(load.direction or [1.0] + [0.0] * (space - 1), dtype=float)
        if load.pressure:
            spec = scene.model
            shells = ([spec.body] if spec.material.kind == "shell" else []) + \
                [part.group for part in spec.shells]
            v = nodal_vectors(mesh, load.group, f"loads[{i}].group", spec.body, space, shells)
            size = np.abs(v).max(initial=0.0)
            for node in np.flatnonzero(np.abs(v).max(axis=1) > 0):
                for c in range(space):
                    if abs(v[node, c]) > 1e-14 * size:      # (not a component's round-off)
                        loads.append(PointLoad(int(node) * dof + c, g, -float(v[node, c])))
        elif load.group is not None:
            w = facet_forces(mesh, load.group, f"loads[{i}].group")
            for node in np.flatnonzero(w):
                for c in range(space):
                    if direction[c]:
                        loads.append(PointLoad(int(node) * dof + c, g, float(w[node] * direction[c])))
        else:
            loads.append(PointLoad(load.node * dof + (load.component or 0), g))
    return loads
