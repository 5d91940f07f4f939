"""A continuum's initial state and body acceleration: scene keys
``initial.motion`` and ``gravity`` on the built model.

:func:`apply` fills u0 and v0 (by group, or every node, with numbers or
expressions of position: :mod:`solver.scene.expression`), in the order the
entries are given, on the translational DOFs (a shell node's rotations start
at rest; a rotating particle's, ``model.lattice.bond: beam``, turn with the
field: half its curl), refuses motion on a fixed DOF naming the entry and the node, and
sets the model's ``gravity``.  The partitions start from u0 and v0 with
a_0 = M^-1 (f(0) - K u_0) and apply m g on every held node
(:class:`solver.partitions.loads.Loads`).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from solver.errors import SceneError
from solver.scene import expression

AXES = "xyz"
ROUND_OFF = 1e-12    # a fixed DOF's initial value up to this x the largest one counts as 0


def apply(arrays, scene, mesh):
    """``arrays`` with u0, v0 and gravity of ``scene`` (unchanged where it gives none)."""
    motion, g = scene.initial.motion, scene.gravity
    dim = arrays.points.shape[1]
    changes = {}
    if g is not None:
        if len(g) != dim:
            raise SceneError(f"gravity: {list(g)} has {len(g)} entries; this {dim}D model needs "
                             f"{dim} (one per axis)")
        if any(g):
            changes["gravity"] = np.array(g, dtype=float)
    if motion:
        changes.update(_motion(arrays, motion, mesh, dim))
    return dataclasses.replace(arrays, **changes) if changes else arrays


def _motion(arrays, motion, mesh, dim) -> dict:
    dm = arrays.dofmap
    state = {"velocity": np.zeros(dm.n_dofs), "displacement": np.zeros(dm.n_dofs)}
    setter = {k: np.full(dm.n_dofs, -1) for k in state}       # the entry that set each DOF
    every = np.arange(arrays.n_nodes)
    for i, entry in enumerate(motion):
        path = f"initial.motion[{i}]"
        nodes = every if entry.group is None else \
            np.asarray(mesh.group(entry.group, f"{path}.group").nodes, dtype=np.int64)
        first = np.asarray(dm.offsets[nodes], dtype=np.int64)
        for name, values in state.items():
            given = getattr(entry, name)
            if given is None:
                continue
            if len(given) != dim:
                raise SceneError(f"{path}.{name}: {list(given)} has {len(given)} entries; this "
                                 f"{dim}D model needs {dim} (one per axis)")
            for c, value in enumerate(given):
                values[first + c] = expression.evaluate(value, arrays.points[nodes],
                                                        f"{path}.{name}[{c}]")
                setter[name][first + c] = i
            if arrays.rotary is not None:              # rotating particles turn with the field
                turns = ~arrays.fixed[first + dim]
                spin = _rotation(given, arrays.points[nodes[turns]], path, name)
                for c in range(arrays.dof - dim):
                    at = first[turns] + dim + c
                    values[at] = spin if dim == 2 else spin[:, c]
                    setter[name][at] = i
    for name, values in state.items():
        # round-off of an expression that vanishes at the support (sin(pi x / L) at
        # x = L: 6e-17) is no motion: it is zeroed; more than that is refused
        fixed = arrays.fixed & (values != 0.0)
        bad = np.flatnonzero(fixed & (np.abs(values) > ROUND_OFF * np.abs(values).max()))
        if bad.size:
            dof = int(bad[0])
            node, c = (int(x[0]) for x in dm.node_of(np.array([dof])))
            raise SceneError(
                f"initial.motion[{setter[name][dof]}].{name}: node {node} at "
                f"{arrays.points[node].tolist()} is held in {AXES[c]} (model.fixed, "
                f"model.constraints or model.prescribed) but would start with {name} "
                f"{values[dof]:g} there ({bad.size} such DOFs); give 0 on held axes or leave "
                "those nodes out of the group")
        values[fixed] = 0.0
    return {"v0": state["velocity"], "u0": state["displacement"]}


def _rotation(given, points, path, name) -> np.ndarray:
    """1/2 curl of the field ``given`` at ``points`` (2D: 1/2 (d g_y/dx - d
    g_x/dy) [n]; 3D: [n, 3]): the rotation (or angular velocity) of a
    particle moving with it (a rigid spin's is the spin), by central
    differences of step 1e-6 x the points' extent (exact for a field linear
    in the coordinates)."""
    dim = points.shape[1]
    h = 1e-6 * max(float(np.ptp(points, axis=0).max(initial=0.0)), 1e-9)

    def slope(c, axis):                  # d g_c / d x_axis
        step = np.zeros(dim)
        step[axis] = h
        label = f"{path}.{name}[{c}]"
        return (expression.evaluate(given[c], points + step, label) -
                expression.evaluate(given[c], points - step, label)) / (2.0 * h)
    if dim == 2:
        return 0.5 * (slope(1, 0) - slope(0, 1))
    return 0.5 * np.stack([slope(2, 1) - slope(1, 2), slope(0, 2) - slope(2, 0),
                           slope(1, 0) - slope(0, 1)], axis=1)


def describe(model) -> list[str]:
    """Log lines of the model's initial motion and gravity (none when at rest
    without gravity)."""
    out = []
    g = model.gravity
    if g is not None:
        weight = float(np.linalg.norm(g)) * float(model.mass.sum())
        out.append(f"gravity {[float(x) for x in g]} m/s^2 on every node's mass (weight "
                   f"{weight:.4g} N)")
    if model.kind != "continuum":
        return out
    dm = model.dofmap
    driven = np.concatenate([m.dofs for m in model.motions] or [np.zeros(0, np.int64)])
    for name, values, unit in (("moving", model.v0, "m/s"), ("displaced", model.u0, "m")):
        if driven.size:                  # (their start is model.prescribed's: its own line)
            values = values.copy()
            values[driven] = 0.0
        if not np.any(values):
            continue
        starts = np.asarray(dm.offsets[np.arange(model.n_nodes)], dtype=np.int64)
        dim = model.points.shape[1]
        vec = values[starts[:, None] + np.arange(dim)]
        size = np.linalg.norm(vec, axis=1)
        out.append(f"initial motion: {int(np.count_nonzero(size))} nodes {name} (largest "
                   f"{size.max():.4g} {unit})")
    return out
