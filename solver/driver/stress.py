"""Stress at continuum probes: sigma_cc along the probe's component c.

Both are linear in the displacement, so each probe is one row of coefficients
over the DOFs of its node and neighbours, in the partition's distributed DOF
numbering: a matrix of the probe rows alone, with the partition operator's
column layout (:func:`probe_rows`), never a partition-sized one.  One MatMult
per system step gives every probe of the partition, its ghosts refreshed by
PETSc whatever the rank layout.

- FE node: the average over the node's FE cells of the cell-averaged stress
  (D B u averaged over the cell's quadrature points), the stress the field
  output writes per cell.
- Shell node (a node of a shell cell, on a shell body or on shells joined to
  a solid): the von Mises stress of the larger face, each shell cell's
  sigma = N / t -+ 6 M / t^2 at its centre in its own frame (the field
  output's von_mises), averaged over the node's shell cells: the probe's
  rows are the cells' face stresses (xx, yy, xy at the top and the bottom,
  linear in u), von Mises is taken after the MatMult.
- Particle (dem partitions): the bond (virial, Love-Weber) stress
  sigma = 1/(2 V) sum_j f_ij (x) r_ij over its bonds, with V = m / rho its
  volume (thickness included in plane stress), f_ij = k (n . (u_j - u_i)) n the
  bond force on i and r_ij = x_j - x_i; a bond carried to band nodes (Zhang et al. 2009
  transition) counts with its band end interpolated from the cell.  With
  nonlinear lattice bonds the lattice part is evaluated in the current
  configuration at every record (broken bonds drop out, contact forces count).  In a
  uniformly strained lattice this is the continuum stress of the calibrated
  material (tests/test_transition.py).
"""
from __future__ import annotations

import numpy as np

from solver.petscutil import init, vec_on
from solver.model.elements import quadrature, strain_matrix
from solver.model.shell import faces, mises


def fe_row(mdl, node: int, c: int, thermal=None):
    """(nodes, coefficients [len(nodes), dim]) of sigma_cc at mesh node ``node``;
    ``thermal`` (a list) receives (nodes, weights) with sigma_th = -alpha sum w dT
    (each cell's D eps_th at its mean temperature)."""
    D = mdl.material_D
    dim = mdl.points.shape[1]
    nodes, coefs, n_cells = [], [], 0
    for fam, conn, _ in mdl.cells:
        if fam.rotations or fam.meshio is None:         # shells, ties: not solid cells
            continue
        hit = np.flatnonzero((conn == node).any(axis=1))
        if not hit.size:
            continue
        _, dNdx, _ = quadrature(fam, mdl.points[conn[hit]])
        op = np.einsum("st,eqtj->esj", D, strain_matrix(dNdx)) / dNdx.shape[1]   # [e, s, k*dim]
        nodes.append(conn[hit].ravel())
        coefs.append(op[:, c, :].reshape(-1, dim))
        n_cells += hit.size
    if not n_cells:
        return np.array([node]), np.zeros((1, dim))
    if thermal is not None:                   # D m, m the unit thermal strain (Voigt)
        m = np.zeros(D.shape[0])
        m[:dim] = 1.0
        k = np.concatenate(nodes).size
        thermal.append((np.concatenate(nodes), np.full(k, (D @ m)[c] / k)))
    return np.concatenate(nodes), np.concatenate(coefs) / n_cells


def shell_rows(mdl, node: int):
    """[(nodes, coefficients [6, 6 k])] of each shell cell at ``node``: the rows
    of its face stresses (top xx, yy, xy, bottom xx, yy, xy; top = +z of the
    cell frame, sigma = N / t - 6 M / t^2 as the fields' stress_top) over its
    nodes' six DOFs; [] when no shell cell has the node."""
    out = []
    for fam, conn, Ke in mdl.cells:
        if not fam.rotations:
            continue
        for c in np.flatnonzero((conn == node).any(axis=1)):
            n = 6 * conn.shape[1]
            one = type(Ke)(Ke.points, conn[[c] * n], Ke.material)   # the cell n times
            N, M, _ = one.resultants(np.eye(n))                       # [n, 3]: per unit DOF
            top, _, bottom = faces(N, M, Ke.material.thickness)
            out.append((conn[c], np.concatenate([top.T, bottom.T])))
    return out


def shell_mises(rows: np.ndarray) -> float:
    """The mean over cells of the larger face's von Mises stress, from the
    cells' face-stress rows [6 n_cells] (:func:`shell_rows`)."""
    return float(mises(rows.reshape(-1, 2, 3)).max(axis=1).mean())


def bond_row(mdl, node: int, c: int, rho: float, lattice: bool = True, thermal=None):
    """(nodes, coefficients) of the bond stress sigma_cc at particle ``node``
    (``lattice`` False: only the bonds carried to a band, the linear part of a
    nonlinear partition); ``thermal`` as in :func:`fe_row` (each bond's rest
    length grown by alpha dT L0 at its ends' mean temperature)."""
    thermal = thermal if thermal is not None else []
    dim = mdl.dof
    V = mdl.mass[node] / rho
    nodes, coefs = [], []
    if mdl.lattice.bonds and lattice:
        bi, bj, k = mdl.lattice.bonds
        for mine, other in ((bi, bj), (bj, bi)):
            sel = np.flatnonzero(mine == node)
            for b in sel:
                r = mdl.points[other[b]] - mdl.points[node]
                L = np.linalg.norm(r)
                n = r / L
                w = k[b] * L * n[c] ** 2 / (2 * V)          # times n . (u_j - u_i)
                nodes += [other[b], node]
                coefs += [w * n, -w * n]
                thermal.append((np.array([other[b], node]), np.full(2, 0.5 * w * L)))
    for _, conn, blocks in mdl.lattice.carried:
        sel = np.flatnonzero(conn[:, -1] == node)             # band-core bonds end on the core
        if hasattr(blocks, "d"):         # beams: f_core,c d_c with f_core = -(K u)_core, d band -> core
            for b in sel:
                rows = blocks[b][-dim:-dim + 2][c] * blocks.d[b][c] / (2 * V)
                nodes += list(conn[b])
                coefs += list(rows.reshape(-1, dim))
            continue
        for b in sel:
            g = blocks.g[b].reshape(-1, dim)                  # elongation = sum_a g_a . u_a
            n = g[-1]                                         # unit vector band -> core
            w = blocks.k[b] * blocks.length[b] * n[c] ** 2 / (2 * V)
            nodes += list(conn[b])
            coefs += list(w * g)
            L = blocks.length[b]
            thermal.append((conn[b], np.full(len(conn[b]), w * L / len(conn[b]))))
    if not nodes:
        return np.array([node]), np.zeros((1, dim))
    return np.array(nodes), np.array(coefs)


class StressProbes:
    """sigma_cc of this rank's probed nodes, one MatMult per partition piece.
    Collective: every piece of a partition builds and evaluates its operator."""

    def __init__(self, scene, mdl, parts):
        self.ops, self.current = [], []
        self.heating = None                  # set by the runner with heat: thermal strain
        self.thermal = {}                    # probe -> (nodes, weights): sigma_th
        self.shell_names = set()             # probes at shell nodes: von Mises
        self.no_stress = set()               # rotation components off the shells: NaN
        rho = scene.model.material.rho
        dim = mdl.dof
        for part in parts:
            entries, names = [], []
            current = []
            nonlinear = not part.force.linear
            for probe in scene.probes:
                loc = part.layout.local(np.array([probe.node]))[0]
                if not 0 <= loc < part.layout.n_owned:
                    continue
                shell = shell_rows(mdl, probe.node) if mdl.shells is not None else []
                if shell:                # face stresses: von Mises after the MatMult
                    first = len(entries)
                    for nodes, coef in shell:
                        cols = (part.dist.number[np.asarray(nodes)][:, None] * dim +
                                np.arange(dim)).ravel()
                        entries += [(cols, row) for row in coef]
                    names.append((probe.name, slice(first, len(entries))))
                    self.shell_names.add(probe.name)
                    continue
                if probe.component >= mdl.points.shape[1]:    # a rotation off the shells
                    self.no_stress.add(probe.name)
                    continue
                th = []
                nodes, coef = (bond_row(mdl, probe.node, probe.component, rho, not nonlinear, th)
                               if part.method == "dem" else
                               fe_row(mdl, probe.node, probe.component, th))
                coef = np.asarray(coef, dtype=float)
                if coef.shape[1] < dim:          # solid cells of a model with shells: 6 DOFs
                    coef = np.pad(coef, ((0, 0), (0, dim - coef.shape[1])))
                if th:
                    self.thermal[probe.name] = (np.concatenate([a for a, _ in th]),
                                                np.concatenate([w for _, w in th]))
                if nonlinear:            # the probe's bonds, found once
                    bonds = part.force.bonds_at(loc)
                    current.append((probe.name, loc, bonds, probe.component,
                                    mdl.mass[probe.node] / rho))
                cols = (part.dist.number[np.asarray(nodes)][:, None] * dim + np.arange(dim)).ravel()
                entries.append((cols, coef.ravel()))
                names.append((probe.name, len(entries) - 1))
            S = probe_rows(part, entries, dim)
            out = np.zeros(len(entries))
            self.ops.append((S, part.u, vec_on(out, part.comm), out, names))
            if nonlinear:               # every piece: the ghost refresh is collective
                self.current.append((part.force, part.u, current))

    def is_shell(self, name: str) -> bool:
        """Probe ``name`` records a shell's von Mises stress (not sigma_cc)."""
        return name in self.shell_names

    def has_stress(self, name: str) -> bool:
        """Probe ``name`` records a stress (not a rotation component off the shells)."""
        return name not in self.no_stress

    def values(self) -> dict:
        """{probe name: sigma} of this rank's probes (collective).  The lattice
        bonds of a nonlinear partition count in their current configuration
        (broken ones not at all): 1/(2V) sum f_c d_c, f the bond's force on the
        probed particle's neighbour side (central: k (L - L0) d / L)."""
        got = dict.fromkeys(self.no_stress, float("nan"))
        heat = self.heating
        for S, u, out_vec, out, rows in self.ops:
            S.mult(u, out_vec)
            for name, i in rows:
                got[name] = shell_mises(out[i]) if isinstance(i, slice) else float(out[i])
                if heat is not None and name in self.thermal:     # minus D eps_th
                    nodes, w = self.thermal[name]
                    dT = heat.T_node[nodes] - heat.spec.initial
                    got[name] -= heat.spec.expansion * float(np.dot(w, dT))
        for force, u, probes in self.current:
            disp = force.displacements(u)           # collective (ghost particles)
            for name, loc, at, c, V in probes:
                got[name] += force.virial(disp, at, c) / (2 * V)
                if force.contact is not None:
                    got[name] += force.contact.stress(disp, force.alive, loc, c) / (2 * V)
        return got

    def destroy(self):
        for S, _, out_vec, _, _ in self.ops:
            S.destroy()
            out_vec.destroy()
        self.ops = []


def probe_rows(part, entries, dim):
    """The matrix of this rank's probe rows of ``part`` (``entries``: one
    (columns, coefficients) per probe, columns in the partition's distributed
    DOF numbering of ``dim`` DOFs a node; a column may repeat: summed), with
    the partition operator's column layout, so that it multiplies the
    partition's displacement Vec.  Collective on the partition's ranks.  A
    MatMult costs the probes' entries, and set-up makes no partition-sized
    matrix (it was a dem rank's set-up peak on the 2.27 M-DOF bar)."""
    P = init()
    n_cols = part.layout.n_held * dim
    S = P.Mat().createAIJ(((len(entries), None), (n_cols, part.dist.n_held * dim)),
                          comm=part.comm)
    # one bound for every row, on and off the diagonal block (per-row arrays
    # hang a rank that has no row: petsc4py then takes another, collective path)
    S.setPreallocationNNZ(max((np.unique(c).size for c, _ in entries), default=1))
    first = S.getOwnershipRange()[0]
    for i, (cols, coef) in enumerate(entries):
        S.setValues([first + i], cols.astype(P.IntType), coef[None, :], addv=True)
    S.assemble()
    return S


def build(scene, mdl, parts):
    """StressProbes when the model is a continuum with probes, else None."""
    if not scene.probes or mdl.kind != "continuum":
        return None
    init()
    return StressProbes(scene, mdl, parts)
