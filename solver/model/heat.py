"""Heat conduction on the body's mesh (``heat``): C dT/dt = -K T + q.

The temperature lives on the mesh nodes of every body cell, the DEM region's
included (with a transition band, the region's cells give its shape and carry
the heat); lattice particles take the temperature of the point they sit on
(the shape functions of their cell), so ``node_temperature`` gives one value
per model node, mesh nodes and particles alike.  K_ab = k t integral of
grad N_a . grad N_b, C the lumped capacity rho c t integral of N_a (t the
plate thickness in plane stress, 1 otherwise), and q the absorbed laser
flux A I(x) integrated with N_a over the plate's surface,
I(r) = 2 I_mean exp(-2 r^2 / R^2) (total power I_mean pi R^2).  Forward
Euler, stable for step <= 2 / lambda_max(C^-1 K), which :func:`build` checks
(the heat is linear and does not feel the mechanics, so every rank steps
the same small system and gets the same temperatures).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.errors import SceneError
from solver.model.embedding import Embedding, flat_cells, locate_in_cells
from solver.model.elements import elastic, FAMILIES, quadrature
from solver.petscutil import init, vec_on


@dataclass
class Conduction:
    spec: object                # the scene's HeatSpec
    indptr: np.ndarray          # K (CSR over mesh nodes)
    indices: np.ndarray
    data: np.ndarray
    capacity: np.ndarray        # [n_mesh] lumped rho c t integral N
    source: np.ndarray          # [n_mesh] absorbed laser power per node [W]
    particles: object           # Embedding of the model nodes after the mesh nodes, or None
    n_model: int
    critical: float             # 2 / lambda_max(C^-1 K)

    def __post_init__(self):
        self._petsc = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_petsc"] = None
        return state

    # ---------------------------------------------------------------- stepping
    def start(self):
        """The thermal state at heating time 0 (T = T0 everywhere)."""
        P = init()
        n = self.capacity.size
        K = P.Mat().createAIJ(size=(n, n), csr=(self.indptr.astype(P.IntType),
                                                self.indices.astype(P.IntType), self.data),
                              comm=P.COMM_SELF)
        K.assemble()
        self.T = np.full(n, self.spec.initial)
        self._flux = np.zeros(n)
        self._petsc = (K, vec_on(self.T, P.COMM_SELF), vec_on(self._flux, P.COMM_SELF))
        self.steps = 0
        self.T_prev = self.T.copy()
        return self

    def step(self):
        """One forward-Euler step of ``spec.step`` seconds of heating."""
        K, T, flux = self._petsc
        self.T_prev[:] = self.T
        t = self.steps * self.spec.step
        laser = self.spec.laser
        K.mult(T, flux)                                     # K T
        np.negative(self._flux, out=self._flux)
        if laser is not None and t >= laser.start:
            self._flux += self.source
        self.T += self.spec.step * self._flux / self.capacity
        self.steps += 1

    def at(self, t_heat: float) -> np.ndarray:
        """Mesh-node temperatures at heating time ``t_heat`` (linear between steps;
        steps forward as needed; time only moves forward)."""
        while self.steps * self.spec.step < t_heat - 1e-12 * self.spec.step:
            self.step()
        if self.steps == 0:
            return self.T.copy()
        s = (t_heat - (self.steps - 1) * self.spec.step) / self.spec.step
        return self.T_prev + min(max(s, 0.0), 1.0) * (self.T - self.T_prev)

    def node_temperature(self, T_mesh: np.ndarray) -> np.ndarray:
        """One temperature per model node (particles interpolated) [n_model]."""
        if self.particles is None:
            return T_mesh.copy()
        return np.concatenate([T_mesh, self.particles.to_particles(T_mesh)])

    def destroy(self):
        if self._petsc is not None:
            for obj in self._petsc:
                obj.destroy()
            self._petsc = None


def _matrices(mesh, cells: dict, spec, material):
    """(K triplets, capacity, laser source) over the mesh nodes."""
    t = material.measure()
    n = len(mesh.points)
    rows, cols, vals = [], [], []
    cap, src = np.zeros(n), np.zeros(n)
    laser = spec.laser
    for fam, conn in cells.items():
        family = FAMILIES[fam]
        X = mesh.points[conn]
        N, dNdx, wdet = quadrature(family, X)
        Ke = spec.conductivity * t * np.einsum("eq,eqai,eqbi->eab", wdet, dNdx, dNdx)
        k = conn.shape[1]
        rows.append(np.repeat(conn, k, axis=1).ravel())
        cols.append(np.tile(conn, (1, k)).ravel())
        vals.append(Ke.ravel())
        rho_c = material.rho * spec.specific_heat * t
        cap += np.bincount(conn.ravel(), (rho_c * np.einsum("eq,qa->ea", wdet, N)).ravel(),
                           minlength=n)
        if laser is not None:
            xq = np.einsum("qa,ead->eqd", N, X)                 # quadrature points
            r2 = np.sum((xq[..., :2] - np.asarray(laser.centre)) ** 2, axis=2)
            flux = laser.absorptivity * 2 * laser.power_density * np.exp(-2 * r2 / laser.radius ** 2)
            src += np.bincount(conn.ravel(), np.einsum("eq,eq,qa->ea", wdet, flux, N).ravel(),
                               minlength=n)
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), cap, src


def build(scene, mesh, particles=None, n_model=None) -> Conduction:
    """The conduction model on the body's cells; ``particles`` [n_p, dim]: the
    model nodes after the mesh nodes (a transition band's core particles)."""
    # lazy: scipy loads only where it is used
    from scipy.sparse import coo_matrix, diags
    from scipy.sparse.linalg import eigsh
    spec, model = scene.heat, scene.model
    body = mesh.group(model.body, "model.body")
    cells = {f: c for f, c in body.cells.items() if f in FAMILIES}        # the body families
    n = len(mesh.points)
    r, c, v, cap, src = _matrices(mesh, cells, spec, elastic(model.material))
    K = coo_matrix((v, (r, c)), shape=(n, n)).tocsr()
    K.sum_duplicates()
    used = cap > 0
    if spec.laser is not None:
        _check_on_body(mesh, cells, spec.laser)
    # lambda_max of C^-1 K on the nodes of the cells
    idx = np.flatnonzero(used)
    s = diags(1.0 / np.sqrt(cap[idx]))
    A = s @ K[idx][:, idx] @ s
    lam = float(eigsh(A, k=1, which="LA", return_eigenvectors=False, tol=1e-6)[0]) \
        if len(idx) > 2 else float(A.diagonal().max() * 2)
    critical = 2.0 / lam
    if spec.step > critical:
        raise SceneError(f"heat.step: {spec.step:g} s is beyond the explicit conduction limit "
                         f"{critical:.4g} s (2 / lambda_max of C^-1 K on this mesh); take "
                         f"heat.step <= {critical:.4g}")
    cap = np.where(used, cap, 1.0)                  # nodes of no cell keep T0
    emb = None
    if particles is not None and len(particles):
        cell, weights = locate_in_cells(mesh.points, cells, particles)
        lost = np.flatnonzero(cell < 0)
        if lost.size:
            raise SceneError(f"heat: particle at {particles[lost[0]].tolist()} lies in no cell of "
                             f"model.body {model.body!r}")
        _, flat = flat_cells(cells)
        emb = Embedding(cell, flat[cell], weights, np.zeros((len(cell), mesh.dim)))
    return Conduction(spec, K.indptr, K.indices, K.data, cap, src, emb,
                      n if n_model is None else n_model, critical)


def _check_on_body(mesh, cells, laser):
    centre = np.zeros((1, mesh.dim))
    centre[0, :2] = laser.centre
    cell, _ = locate_in_cells(mesh.points, cells, centre)
    if cell[0] < 0:
        lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
        raise SceneError(f"heat.laser.centre: {list(laser.centre)} lies off the plate (model.body "
                         f"spans {lo[:2].tolist()} to {hi[:2].tolist()})")
