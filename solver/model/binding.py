"""The scene bound to its model data: the checks that need the mesh or the
network, and the resolved scene the later stages run.

The scene stage parses and validates its own keys and reads no model data;
:func:`load`, :func:`load_with_text` and :func:`from_dict` here parse and bind,
for the entry points (:mod:`solver.tools.cli`, :mod:`solver.tools.api`).

:func:`bind` reads the model data once (:mod:`solver.model.data`), checks
every key that refers to it (physical groups, node ids, components, load
directions, the material against the mesh's dimension, each node owned by
exactly one partition) and returns the scene with mesh groups and probe
coordinates turned into node ids.  Errors are one line naming the key.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from solver.model import data as model_data
from solver.model.elements import CELLS, FAMILIES
from solver.scene import file as scene_file
from solver.scene.model_spec import DOF_NAMES
from solver.scene.node_set import NodeSet
from solver.scene.sections import AUTO, Partition
from solver.scene.schema import fail, shown
from solver.model.shell_model import shell_cells, shell_nodes
from solver.model.boundary import fixed_dofs


def dof(scene, data) -> int:
    """DOFs per node: the mesh's dimension for continua (6 for shells), 1 for
    networks."""
    if scene.model.kind != "continuum":
        return 1
    return 6 if scene.model.material.kind == "shell" or scene.model.shells else data.dim


def from_dict(raw: dict, store=None):
    """A scene from plain data, parsed (:func:`solver.scene.file.from_dict`) and bound."""
    return bind(scene_file.from_dict(raw), store)


def load(path, overrides=(), store=None):
    """A scene file read with ``key.path=value`` overrides, parsed and bound."""
    return load_with_text(path, overrides, store)[0]


def load_with_text(path, overrides=(), store=None):
    """(the bound scene, the effective scene as YAML); errors name the file."""
    return scene_file.load_with_text(path, overrides, then=lambda scene: bind(scene, store))


def bind(scene, store=None):
    """``scene`` checked against its model data, groups and probe points resolved.
    ``store``: the run's :class:`~solver.model.data.ModelData` (the model build
    reuses what binding read), or None to read afresh."""
    store = store if store is not None else model_data.ModelData()
    data = store.read(scene.model)
    if scene.analysis == "static":
        scene = _static(scene)
    if scene.partitions == AUTO:
        scene = dataclasses.replace(scene, partitions=(_everything(scene, data),))
    continuum = scene.model.kind == "continuum"
    zone = None
    if continuum:
        zone = _check_continuum(scene.model, data, store)
    n, d = model_data.n_nodes(data), dof(scene, data)
    if zone is not None:
        n += zone.n_core
    owned = _owned_nodes(scene, data, n, zone)
    if continuum:
        _check_free(scene, data, owned, d)
    loads = []
    stepped = np.zeros(n, bool)
    for nodes in owned:
        stepped[np.asarray(nodes, dtype=np.int64)] = True
    for i, motion in enumerate(scene.model.prescribed if continuum else ()):
        _check_carried(motion.group, f"model.prescribed[{i}].group", data, stepped,
                       "a motion there would drive nothing")
    if continuum and scene.model.prescribed:
        levelled = [p.name for p in scene.partitions if p.integrator == "levels"]
        if levelled:
            fail("model.prescribed", f"partition '{levelled[0]}' steps by element levels "
                 "(partitions: auto), which set no prescribed motion yet: give the partitions "
                 "(integrator explicit, implicit or verlet)")
    for i, ld in enumerate(scene.loads):
        if ld.group is not None:
            ld = _traction(ld, f"loads[{i}]", data, data.points.shape[1] if continuum else d)
            _check_carried(ld.group, f"loads[{i}].group", data, stepped)
        else:
            if ld.at is not None and not continuum:
                fail(f"loads[{i}].at", "a point needs a continuum model (give node)")
            node = ld.node if ld.node is not None else snap(scene.model, data, ld.at,
                                                            f"loads[{i}].at", zone)
            _check_dof(f"loads[{i}]", node, ld.component or 0, n, d)
            loads.append(dataclasses.replace(ld, node=node, at=None, component=ld.component or 0))
            continue
        loads.append(ld)
    for kind in ("displacement", "velocity"):
        for node in getattr(scene.initial, kind):
            _check_dof(f"initial.{kind}.{node}", node, 0, n, d)
    probes = []
    for i, probe in enumerate(scene.probes):
        node = probe.node if probe.node is not None else snap(scene.model, data, probe.at,
                                                              f"probes[{i}].at", zone)
        _check_dof(f"probes[{i}]", node, probe.component, n, d)
        probes.append(dataclasses.replace(probe, node=node))
    parts = tuple(dataclasses.replace(p, nodes=nodes, group=None)
                  for p, nodes in zip(scene.partitions, owned))
    return dataclasses.replace(scene, partitions=parts, probes=tuple(probes), loads=tuple(loads))


FACETS = FAMILIES.facets()          # the cells that carry tractions: edges and faces


def _traction(ld, path, mesh, space):
    """Group load ``ld`` checked against the mesh: its group holds edges or
    faces, its direction has ``space`` components; a component c becomes the
    direction e_c."""
    group = mesh.group(ld.group, f"{path}.group")
    if not any(f in group.cells for f in FACETS):
        fail(f"{path}.group", f"group {ld.group!r} (dim {group.dim}, "
             f"{', '.join(group.cells) or 'no cells'}) has no edges or faces to carry a traction")
    if ld.pressure:
        dims = sorted({CELLS[f].dim for f in group.cells})
        if dims != [space - 1]:
            fail(f"{path}.group", f"group {ld.group!r} has {', '.join(group.cells)} cells: a "
                 f"pressure acts on {'faces' if space == 3 else 'edges'} (a surface's cells in "
                 f"3D, edges in 2D)")
        return ld
    if ld.direction is not None and len(ld.direction) != space:
        fail(f"{path}.direction", f"needs {space} components")
    if ld.component is not None:
        if ld.component >= space:
            fail(f"{path}.component", f"component {ld.component} out of range: a traction on "
                 f"group {ld.group!r} has {space} components ({', '.join('xyz'[:space])} = "
                 f"{', '.join(map(str, range(space)))})")
        if ld.direction is not None:
            fail(f"{path}.component", "a group load's traction acts along direction: give "
                 "direction or component, not both")
        axis = tuple(float(c == ld.component) for c in range(space))
        ld = dataclasses.replace(ld, direction=axis, component=None)
    return ld


def _check_carried(name, key, mesh, stepped, what="a load there would move nothing"):
    """A group load's nodes are all the body's (stepped by a partition): a load
    on nodes no cell of the body uses would move nothing, in silence."""
    nodes = mesh.group(name).nodes
    off = ~stepped[nodes]
    if off.any():
        node = int(nodes[off][0])
        fail(key, f"group {name!r}: {int(off.sum())} of its {nodes.size} nodes are on no cell of "
             f"the body (node {node} at {mesh.points[node].round(6).tolist()}): {what}")


def _check_continuum(spec, mesh, store):
    mesh.group(spec.body, "model.body")
    for name in spec.fixed:
        mesh.group(name, "model.fixed")
    if spec.lattice is not None:
        mesh.group(spec.lattice.region, "model.lattice.region")
    kind = spec.material.kind
    if (mesh.dim == 3) != (kind == "solid"):
        wants = "solid" if mesh.dim == 3 else ("plane_stress", "plane_strain", "shell")
        fail("model.material.kind", f"{kind} does not fit a {mesh.dim}D mesh "
             f"(use {wants})")
    if kind == "shell":
        shell_cells(mesh, spec.body, "model.body")
    if kind in ("plane_stress", "plane_strain") and mesh.z_span > 0:
        fail("model.material.kind", f"{kind} needs a plane mesh (z = const); this surface "
             f"spans {mesh.z_span:.3g} m in z: use shell")
    if kind == "shell":
        _check_wall(mesh, spec.body, spec.material.thickness, "model.material.thickness")
    for i, sec in enumerate(spec.sections):
        shell_cells(mesh, sec.group, f"model.sections[{i}].group")
        _check_wall(mesh, sec.group, sec.thickness, f"model.sections[{i}].thickness")
    for i, part in enumerate(spec.shells):
        shell_cells(mesh, part.group, f"model.shells[{i}].group")
        _check_wall(mesh, part.group, part.thickness, f"model.shells[{i}].thickness")
    names = DOF_NAMES if kind == "shell" or spec.shells else DOF_NAMES[:mesh.dim]
    for where, entries in (("constraints", spec.constraints), ("prescribed", spec.prescribed)):
        for i, c in enumerate(entries):
            mesh.group(c.group, f"model.{where}[{i}].group")
            bad = [d for d in c.dofs if d not in names]
            if bad:
                fail(f"model.{where}[{i}].dofs", f"{bad[0]} does not exist: a {kind} model's "
                     f"nodes have {', '.join(names)}")
    turned = [(i, m) for i, m in enumerate(spec.prescribed) if set(m.dofs) & set(DOF_NAMES[3:])]
    if spec.shells and turned:                       # a solid-only node has no rotation to drive
        on_shell = np.unique(np.concatenate([shell_nodes(mesh, p.group) for p in spec.shells]))
        for i, m in turned:
            nodes = mesh.group(m.group).nodes
            off = nodes[~np.isin(nodes, on_shell)]
            if off.size:
                node = int(off[0])
                fail(f"model.prescribed[{i}].dofs", f"{[d for d in m.dofs if d[0] == 'r']}: "
                     f"node {node} at {mesh.points[node].round(6).tolist()} is a solid node "
                     f"({off.size} in group {m.group!r}): only shell nodes rotate")
    if spec.lattice is not None and spec.lattice.transition:
        return store.transition(spec, mesh)
    return None


THINNEST_WALL = 1e-6   # a shell wall is thicker than this x its smallest element edge


def _check_wall(mesh, group, thickness, key):
    """A shell's thickness against its element size: bending goes as t^3 and a
    node's rotary inertia as t^3 A, so a wall a millionth of its elements' size
    or thinner is no shell to step (t^3 underflows, the step has no scale)."""
    edges = np.concatenate([np.linalg.norm(mesh.points[conn] - np.roll(mesh.points[conn], 1, axis=1),
                                           axis=2).ravel()
                            for _, conn, _ in shell_cells(mesh, group, key)])
    h = float(edges[edges > 0].min()) if (edges > 0).any() else 0.0
    if thickness <= THINNEST_WALL * h:
        fail(key, f"{thickness:g} m is too thin for shell group {group!r}: a wall must be "
             f"thicker than {THINNEST_WALL:g} x its smallest element edge ({h:.3g} m), i.e. "
             f"above {THINNEST_WALL * h:.3g} m")


def _check_free(scene, data, owned, d):
    """Every partition has a DOF that moves: a partition whose every node has
    every DOF held (model.fixed, model.constraints) has nothing to step."""
    n_mesh = model_data.n_nodes(data)
    held = fixed_dofs(scene, data, n_mesh, d).reshape(n_mesh, d)
    spec = scene.model
    if spec.shells:                                  # solid-only nodes never rotate
        on_shell = np.zeros(n_mesh, bool)
        for part in spec.shells:
            on_shell[shell_nodes(data, part.group)] = True
        held[~on_shell, 3:] = True
    free = ~held.all(axis=1)
    for p, nodes in enumerate(owned):
        nodes = np.asarray(nodes, dtype=np.int64)
        if nodes.size and not free[nodes[nodes < n_mesh]].any() and not (nodes >= n_mesh).any():
            part = scene.partitions[p]
            fail(f"partitions[{p}]", f"partition '{part.name}' has no free DOF: every DOF of its "
                 f"{nodes.size} nodes is held by model.fixed, model.constraints or "
                 "model.prescribed, so nothing would move (free some, or leave those nodes out)")


def _used(data, body, zone, n, shells=()):
    """Nodes the model steps: the nodes of the body's cells (without a
    transition band) and of its shell surfaces, or of its FE and band cells
    and the core particles."""
    used = np.zeros(n, bool)
    for conn in shells:
        used[conn] = True
    cells = body.cells if zone is None else {**zone.fe_cells, **{f"band {k}": c for k, c in
                                                                 zone.band_cells.items()}}
    for conn in cells.values():
        used[conn] = True
    if zone is not None:
        used[zone.core_ids] = True
    return used


def _everything(scene, data):
    """``partitions: auto`` before levelling: one partition over the whole body
    (``integrator: levels``; solver.partitions.levels makes the levels)."""
    where = dict(group=scene.model.body) if scene.model.kind == "continuum" else \
        dict(nodes=NodeSet(np.arange(model_data.n_nodes(data))))
    return Partition(name="auto", method="fem", integrator="levels", ratio=1, beta=0.0,
                     gamma=0.5, **where)


def _static(scene):
    """``analysis: static``: one explicit fem partition (the given one's nodes, or
    the body) and one system step, to time.end: the static solve stands in for
    it (:mod:`solver.driver.static`)."""
    given = scene.partitions[0] if scene.partitions else None
    where = dict(group=scene.model.body) if given is None else \
        dict(group=given.group, nodes=given.nodes)
    part = Partition(name=given.name if given else "static", method="fem",
                     integrator="explicit", ratio=1, **where)
    return dataclasses.replace(scene, partitions=(part,),
                               time=dataclasses.replace(scene.time, dt=scene.time.end))


def _owned_nodes(scene, data, n, zone=None) -> list[NodeSet]:
    """Node ids of every partition (a node in two groups stays with the earlier
    partition); every node in range and owned exactly once.  With a transition
    band, a dem partition owns the core particles and groups keep only the
    mesh nodes of FE and band cells."""
    owner = np.full(n, -1, dtype=np.int64)
    continuum = scene.model.kind == "continuum"
    used = _used(data, data.group(scene.model.body, "model.body"), zone, n,
                 [shell_nodes(data, p.group) for p in scene.model.shells]) \
        if continuum else np.ones(n, bool)
    out = []
    for p, part in enumerate(scene.partitions):
        if zone is not None and part.method == "dem":
            nodes = zone.core_ids
            nodes = nodes[owner[nodes] < 0]
        elif part.group is not None:
            nodes = data.group(part.group, f"partitions[{p}].group").nodes
            nodes = np.asarray(nodes, dtype=np.int64)
            nodes = nodes[(owner[nodes] < 0) & used[nodes]]
        else:
            nodes = np.asarray(part.nodes, dtype=np.int64)
            bad = nodes[nodes >= n]
            if bad.size:
                fail(f"partitions[{p}].nodes", f"node {int(bad[0])} out of range (model has {n} nodes)")
            uniq, counts = np.unique(nodes, return_counts=True)
            taken = uniq[(owner[uniq] >= 0) | (counts > 1)]
            if taken.size:
                node = int(taken[0])
                first = scene.partitions[owner[node]].name if owner[node] >= 0 else part.name
                fail(f"partitions[{p}].nodes",
                     f"node {node} is owned by partitions '{first}' and '{part.name}'")
        owner[nodes] = p
        out.append(NodeSet(nodes))
    for p, nodes in enumerate(out):
        if not nodes:
            part = scene.partitions[p]
            where = (f"the nodes of group {shown(part.group)} that the body's cells use all "
                     "belong to earlier partitions" if part.group is not None else
                     "its nodes belong to earlier partitions")
            fail(f"partitions[{p}]", f"partition '{part.name}' owns no node ({where})")
    # mesh nodes no body cell uses (a geometry kernel's centre point, say) are left out
    orphans = np.flatnonzero((owner < 0) & used)
    if orphans.size:
        fail("partitions", f"nodes {orphans[:10].tolist()} are owned by no partition")
    return out


def snap(spec, mesh, at, key, zone=None) -> int:
    """The body node nearest to point ``at``; refused when the point is farther
    from it than the cells around that node reach (outside the body).  With a
    transition band: the nearest node of the FE cells or core particle (which
    reaches one lattice diagonal)."""
    pts = mesh.points
    dim = pts.shape[1]
    if len(at) < dim or any(x != 0 for x in at[dim:]):
        fail(key, f"{list(at)}: a point of the {dim}D mesh needs {dim} coordinates")
    body = list(mesh.group(spec.body, "model.body").cells.values() if zone is None else
                zone.fe_cells.values())
    body += [conn for i, p in enumerate(spec.shells)
             for _, conn, _ in shell_cells(mesh, p.group, f"model.shells[{i}].group")]
    nodes = np.unique(np.concatenate([c.ravel() for c in body])) if body else np.zeros(0, int)
    p = np.asarray(at[:dim], dtype=float)
    if zone is not None:
        pts = np.concatenate([pts, zone.points])
        nodes = np.concatenate([nodes, zone.core_ids])
    dist = np.linalg.norm(pts[nodes] - p, axis=1)
    node = int(nodes[np.argmin(dist)])
    if zone is not None and node >= zone.n_mesh:
        reach = zone.spacing * np.sqrt(dim)
    else:
        reach = max((float(np.linalg.norm(pts[c[np.any(c == node, axis=1)]] - pts[node],
                                          axis=2).max())
                     for c in body if np.any(c == node)), default=0.0)
    if dist.min() > reach:
        fail(key, f"{list(at)} is {dist.min():.3g} m from the nearest body node {node} at "
                  f"{pts[node].tolist()}, farther than its cells reach ({reach:.3g} m): outside "
                  "the body?")
    return node


def _check_dof(path, node, component, n, d):
    if node < 0 or node >= n:
        fail(f"{path}.node" if "initial" not in path else path,
             f"node {node} out of range (model has {n} nodes)")
    if component >= d:
        fail(f"{path}.component", f"component {component} out of range (nodes have {d} DOF)")
