"""Prescribed motion (scene key ``model.prescribed``): chosen DOFs of physical
groups that move with a given velocity or displacement in time.

A prescribed DOF is held like a fixed one (no acceleration solve: zero
inverse mass, an identity row in an implicit partition's matrix) and its
displacement and velocity are set to the exact values g(t), g'(t) (or
the integral of g and g) before every force evaluation, so the free DOFs
feel the motion through the stiffness (:mod:`solver.partitions.motion`).
A velocity's displacement is its integral from t = 0: the DOFs start where
they are; a displacement g(0) != 0 starts the model displaced there.  The
static solve lifts the prescribed displacement (:mod:`solver.driver.static`).

:func:`held` is the DOF mask :func:`solver.model.boundary.fixed_dofs` adds
to the fixed ones (refusing a DOF that is both, or prescribed twice);
:func:`apply` gives the built model its :class:`Motion` list and the
initial state of the prescribed DOFs.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from solver.errors import SceneError
from solver.model.loads import LoadFunction, load_function
from solver.scene.model_spec import DOF_NAMES


@dataclass(frozen=True)
class Motion:
    """The DOFs (model indices) of one ``model.prescribed`` entry and their motion."""

    key: int                 # the entry's index in model.prescribed
    dofs: np.ndarray
    function: LoadFunction
    velocity: bool           # the function gives the velocity (else the displacement)
    kind: str = ""           # the scene's name of the function (the log's)

    def at(self, t: float) -> tuple[float, float]:
        """(displacement, velocity) at time t."""
        f = self.function
        if self.velocity:
            return f.integral(t), f.at(t)
        return f.at(t), f.rate(t)

    def describe(self) -> str:
        return (f"prescribed[{self.key}]: {self.dofs.size} DOFs move with a given "
                f"{'velocity' if self.velocity else 'displacement'} "
                f"({self.kind})")


def entry_dofs(scene, mesh, n_nodes: int, dof: int):
    """[(entry index, model DOF indices)] of ``model.prescribed`` on a uniform
    DOF map of ``dof`` per node."""
    out = []
    for i, entry in enumerate(scene.model.prescribed):
        nodes = np.asarray(mesh.group(entry.group, f"model.prescribed[{i}].group").nodes,
                           dtype=np.int64)
        comps = np.array([DOF_NAMES.index(d) for d in entry.dofs])
        if comps.max() >= dof:
            raise SceneError(f"model.prescribed[{i}].dofs: {DOF_NAMES[comps.max()]} does not "
                             f"exist: this model's nodes have {', '.join(DOF_NAMES[:dof])}")
        out.append((i, np.sort((nodes[:, None] * dof + comps).ravel())))
    return out


def held(scene, mesh, n_nodes: int, dof: int, fixed: np.ndarray) -> np.ndarray:
    """[n_nodes * dof] bool: the prescribed DOFs; a DOF in ``fixed`` (model.fixed,
    model.constraints) or in two entries is refused, naming the node."""
    mask = np.zeros(n_nodes * dof, bool)
    by = np.full(n_nodes * dof, -1)
    for i, dofs in entry_dofs(scene, mesh, n_nodes, dof):
        for clash, other in ((fixed[dofs], "model.fixed or model.constraints"),
                             (mask[dofs], None)):
            if clash.any():
                d = int(dofs[clash][0])
                node, c = divmod(d, dof)
                held_by = other or f"model.prescribed[{by[d]}]"
                raise SceneError(
                    f"model.prescribed[{i}].group: node {node} at "
                    f"{np.round(mesh.points[node], 6).tolist()} has {DOF_NAMES[c]} held by "
                    f"{held_by} already ({int(clash.sum())} such DOFs); a DOF is fixed or "
                    "moved by one entry")
        mask[dofs] = True
        by[dofs] = i
    return mask


def apply(arrays, scene, mesh):
    """``arrays`` with its motions and the prescribed DOFs' initial displacement
    and velocity (their values at t = 0); unchanged without model.prescribed."""
    spec = scene.model.prescribed
    if not spec:
        return arrays
    dof = arrays.dofmap.block
    motions = tuple(Motion(i, dofs, load_function(spec[i]), spec[i].quantity == "velocity",
                           spec[i].kind)
                    for i, dofs in entry_dofs(scene, mesh, arrays.n_nodes, dof))
    u0, v0 = arrays.u0.copy(), arrays.v0.copy()
    for m in motions:
        u0[m.dofs], v0[m.dofs] = m.at(0.0)
    return dataclasses.replace(arrays, motions=motions, u0=u0, v0=v0)


def describe(model) -> list[str]:
    """Log lines of the model's prescribed motions."""
    return [m.describe() for m in model.motions]
