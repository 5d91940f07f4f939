"""Continuum model from a gmsh mesh: the same interface as the network Model.

Nodes are mesh nodes with ``dim`` DOFs each (index ``node * dim + c``).  The
stiffness of a set of held nodes is assembled from the body's cells whose
nodes are all held; every node's lumped mass sums its cells' shares; nodes of
``fixed`` groups have all DOFs fixed (their accelerations stay zero).
Tractions on boundary groups become consistent nodal forces (a line load
q [N/m] on a 2D edge, a pressure-like load [N/m^2] on a 3D face).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar

import numpy as np

from solver.laws import CONTACT_LAWS, ContactSettings
from solver.model import data as model_data, dilatation, heat, initial, prescribed, shell_model
from solver.model.cell_blocks import group_matrices, kept, nodal
from solver.model.boundary import fixed_dofs, load_list
from solver.model.dofmap import DofMap
from solver.model.graph import Graph
from solver.model.elements import elastic
from solver.model.interface import Lattice, Shells
from solver.errors import SceneError
from solver.memory import zeros_if_zero
from solver.model.calibration import ROTATING_DOFS, beams_at_rest
from solver.model.lattice import cubic, square


@dataclass(frozen=True)
class ContinuumArrays:
    """A continuum model (:class:`solver.model.interface.ModelInterface`), built
    with keywords; the optional features are None when absent."""

    dof: int
    points: np.ndarray
    mass: np.ndarray             # [n_nodes] lumped
    cells: list                  # (family, conn, CellStiffness) per cell family of the body
    fixed: np.ndarray            # [n_nodes * dof] bool
    loads: tuple
    u0: np.ndarray
    v0: np.ndarray
    material_D: np.ndarray = None  # elasticity matrix (Voigt), for stresses
    notes: tuple = ()              # what reading the mesh changed (solver.model.mesh), logged
    shells: Shells | None = None   # shell surfaces (rotary inertia), or None
    lattice: Lattice | None = None  # lattice bonds, overlap and carried cells, bond law, or None
    contact: ContactSettings | None = None        # settings of model.lattice.contact (contact_of), or None
    heat: object = None            # solver.model.heat.Conduction (scene key heat), or None
    zone: object = None            # the Transition (model.lattice.transition), else None
    rotary: np.ndarray | None = None   # [n_nodes] inertia of rotating particles' rotations, or None
    gravity: np.ndarray | None = None   # body acceleration [dim] (scene key gravity), or None
    motions: tuple = ()            # prescribed motions (solver.model.prescribed.Motion)

    kind: ClassVar[str] = "continuum"

    @property
    def n_nodes(self) -> int:
        return self.mass.size

    @cached_property
    def dofmap(self) -> DofMap:
        return DofMap.uniform(self.n_nodes, self.dof)

    @property
    def n_dofs(self) -> int:
        return self.dofmap.n_dofs

    def _held(self, held):
        inh = np.zeros(self.n_nodes, bool)
        inh[held] = True
        return inh

    def share(self, nodes, body_cells: bool = True) -> "ContinuumArrays":
        """This model with only the cells and bonds that touch ``nodes``: what a
        rank holding those nodes assembles (node arrays keep global ids; an
        all-zero u0 or v0 travels as np.zeros).  ``body_cells`` False: none of
        the body's cells, for a rank that steps no fem partition (without a
        transition band a dem piece applies bonds, overlap and carried cells)."""
        inh = self._held(nodes)
        body = inh if body_cells or self.zone is not None else np.zeros_like(inh)

        def touching(cells, inh=inh):
            return [(fam, *kept(conn, Ke, inh[conn].any(axis=1))) for fam, conn, Ke in cells]
        lat = self.lattice
        if lat is not None:
            bonds = lat.bonds
            bending = lat.bending
            if bonds:
                bi, bj, k = bonds
                near = inh
                if lat.dilatation is not None:     # the whole stars of the held nodes' neighbours
                    near = inh.copy()
                    near[bj[inh[bi]]] = near[bi[inh[bj]]] = True
                keep = near[bi] | near[bj]
                bonds = (bi[keep], bj[keep], k[keep])
                bending = bending[keep] if bending is not None else None
            lat = dataclasses.replace(lat, bonds=bonds, overlap_cells=touching(lat.overlap_cells),
                                      carried=touching(lat.carried), bending=bending)
        return dataclasses.replace(self, cells=touching(self.cells, body), lattice=lat,
                                   u0=zeros_if_zero(self.u0), v0=zeros_if_zero(self.v0))

    def _cell_blocks(self, cells, held) -> list:
        inh = self._held(held)
        return [kept(conn, Ke, np.all(inh[conn], axis=1)) for _, conn, Ke in cells]

    def stiffness_blocks(self, held: np.ndarray) -> list:
        """Block sets (global node ids) of the body cells whose nodes are all held.
        With a transition band every held element counts, cells, carried bonds
        and lattice bonds alike: the FE side holds core particles only as
        externals, and a single partition over everything (a monolithic
        reference) is then the whole model."""
        if self.zone is not None:
            return self._lattice_blocks(held) + self._cell_blocks(self.cells, held)
        return self._cell_blocks(self.cells, held)

    def bond_blocks(self, held: np.ndarray) -> list:
        """Block sets of the lattice bonds whose ends are held (k n n^T [[1, -1],
        [-1, 1]]) and of the overlap cells, which both sides share (with a
        transition band: every held element, as :meth:`stiffness_blocks`)."""
        if self.zone is not None:
            return self.stiffness_blocks(held)
        return self._lattice_blocks(held)

    def _lattice_blocks(self, held: np.ndarray) -> list:
        lat = self.lattice
        if lat is None:
            return []
        out = []
        if lat.bonds:
            bi, bj, k = lat.bonds
            inh = self._held(held)
            keep = inh[bi] & inh[bj]
            conn = np.stack([bi[keep], bj[keep]], axis=1)
            out.append((conn, BondStiffness(self.points, conn, k[keep]) if lat.bending is None
                        else BeamStiffness(self.points, conn, k[keep], lat.bending[keep])))
            if lat.dilatation is not None:
                out += lat.dilatation.blocks(self.points, bi[keep], bj[keep], held)
        return out + self._cell_blocks(lat.overlap_cells, held) + \
            self._cell_blocks(lat.carried, held)

    def graph(self) -> Graph:
        """Adjacent nodes of every node, through the body's cells, the carried
        cells and the lattice bonds (:meth:`Graph.from_cells`: the pattern of
        C^T C, no edge keys)."""
        lat = self.lattice
        conns = [conn for _, conn, _ in list(self.cells) + list(lat.carried if lat is not None else ())]
        if lat is not None and lat.bonds:
            conns.append(tuple(lat.bonds[:2]))          # (the ends as they are: no copy)
            if lat.dilatation is not None:              # a star couples its particles
                conns += [conn for conn, _ in lat.dilatation.blocks(
                    self.points, *lat.bonds[:2], np.arange(self.n_nodes))]
        return Graph.from_cells(self.n_nodes, conns)


class BondStiffness:
    """Blocks k n n^T [[1, -1], [-1, 1]] of central bonds, computed when asked
    (``blocks[idx]``), like :class:`solver.model.cell_blocks.CellStiffness`."""

    def __init__(self, points, conn, k):
        self.points, self.conn, self.k = points, conn, k

    def __len__(self) -> int:
        return len(self.conn)

    @classmethod
    def joined(cls, parts, conn) -> "BondStiffness":
        """The bonds of ``parts`` (their connectivities together: ``conn``)."""
        return cls(parts[0].points, conn, np.concatenate([p.k for p in parts]))

    def __getitem__(self, idx) -> np.ndarray:
        c, k = self.conn[idx], self.k[idx]
        n = self.points[c[:, 1]] - self.points[c[:, 0]]
        n = n / np.linalg.norm(n, axis=1)[:, None]
        nn = k[:, None, None] * np.einsum("bi,bj->bij", n, n)
        return np.block([[nn, -nn], [-nn, nn]])


class BeamStiffness(BondStiffness):
    """Blocks of beam bonds at rest (axial k, bending k_b; [6, 6] on the DOFs
    (u_x, u_y, theta) of their two particles in 2D, [12, 12] on (u, theta) in
    3D: :func:`solver.model.calibration.beams_at_rest`), computed when asked."""

    def __init__(self, points, conn, k, k_b):
        super().__init__(points, conn, k)
        self.k_b = k_b

    def __getitem__(self, idx) -> np.ndarray:
        c = self.conn[idx]
        return beams_at_rest(self.points[c[:, 1]] - self.points[c[:, 0]], self.k[idx],
                             self.k_b[idx])

    @classmethod
    def joined(cls, parts, conn) -> "BeamStiffness":
        return cls(parts[0].points, conn, np.concatenate([p.k for p in parts]),
                   np.concatenate([p.k_b for p in parts]))

    def subset(self, mask) -> "BeamStiffness":
        return BeamStiffness(self.points, self.conn[mask], self.k[mask], self.k_b[mask])


def attach_lattice(scene, mesh, mass, cells, reach: int = 1):
    """Bonds, overlap cells and particle masses of the scene's lattice on the mesh
    nodes that coincide with its sites: (bonds, overlap cells, mass with particle
    masses for dem-owned nodes).  The lattice reaches ``reach`` spacings beyond
    its region (the external layers of the dem partitions, which the coupling
    stage decides), so that external particles carry their bonds."""
    spec, mat = scene.model.lattice, scene.model.material
    region = mesh.group(spec.region, "model.lattice.region")
    pts = mesh.points
    a = spec.spacing
    lo = pts[region.nodes].min(axis=0) - reach * a
    hi = pts[region.nodes].max(axis=0) + reach * a
    lo, hi = np.maximum(lo, pts.min(axis=0)), np.minimum(hi, pts.max(axis=0))
    shape = np.rint((hi - lo) / a).astype(int) + 1
    try:
        E = spec.E or mat.E
        lat = (square(lo, shape, a, E, mat.nu, mat.rho, mat.depth, mat.kind)
               if mesh.dim == 2 else cubic(lo, shape, a, E, mat.nu, mat.rho))
    except ValueError as e:
        raise SceneError(f"model.lattice: {e}") from None
    # pair every lattice site with the mesh node at the same place
    cell = np.rint((pts - lo) / a).astype(np.int64)
    on_grid = np.all(np.abs(pts - (lo + cell * a)) <= 1e-3 * a, axis=1) & \
        np.all((cell >= 0) & (cell < shape), axis=1)
    site_of = np.full(int(np.prod(shape)), -1, dtype=np.int64)
    site_of[np.ravel_multi_index(tuple(cell[on_grid].T), tuple(shape))] = np.flatnonzero(on_grid)
    del cell, on_grid
    missing = np.flatnonzero(site_of < 0)
    if missing.size:
        where = ", ".join("(" + ", ".join(f"{c:.6g}" for c in p) + ")" for p in lat.points[missing[:5]])
        raise SceneError(f"model.lattice: {missing.size} lattice sites have no mesh node within "
                         f"{1e-3 * a:.3g} m (the mesh must coincide with the lattice one spacing "
                         f"around region {spec.region!r}): {where}{' ...' if missing.size > 5 else ''}")
    particle_mass = np.zeros(len(pts))
    particle_mass[site_of] = lat.mass
    dem_nodes = [np.asarray(nodes, dtype=np.int64) for part, nodes in
                 ((p, p.nodes) for p in scene.partitions) if part.method == "dem"]
    is_dem = np.zeros(len(pts), bool)
    if dem_nodes:
        is_dem[np.concatenate(dem_nodes)] = True
    # lattice cells with corners of both sides are overlap cells: both partitions
    # use the mesh cell there; the bonds come from the other lattice cells
    corners = site_of[lat.corners]
    n_dem = is_dem[corners].sum(axis=1)
    mixed = (n_dem > 0) & (n_dem < corners.shape[1])
    wanted = np.sort(corners[mixed], axis=1)
    del corners, n_dem, is_dem
    # in mesh numbering, sorted once (each temporary let go as soon as it is
    # used: on the 2.27 M-DOF bar these arrays are 4 M bonds long)
    si, sj, bk = lat.bonds(~mixed, order=False)
    del lat                          # (its sites and cells)
    a_ = site_of[si]
    del si
    b_ = site_of[sj]
    del sj
    bi = np.minimum(a_, b_)
    bj = np.maximum(a_, b_, out=a_)
    del a_, b_
    order = np.argsort(bi * np.int64(len(pts)) + bj)
    bi = bi[order]
    bj = bj[order]
    bk = bk[order]
    del order
    overlap = []
    if mixed.any():
        for fam, conn, Ke in cells:
            hit = same_corners(conn, wanted)
            if hit.any():
                overlap.append((fam, conn[hit], Ke[hit]))
        found = sum(len(c) for _, c, _ in overlap)
        if found != mixed.sum():
            raise SceneError(f"model.lattice: {mixed.sum() - found} overlap cells of the lattice "
                             "have no mesh cell with the same corners")
    mass = mass.copy()
    if dem_nodes:
        dem = np.concatenate(dem_nodes)
        outside = dem[particle_mass[dem] == 0]
        if outside.size:
            raise SceneError(f"model.lattice: dem partition nodes {outside[:5].tolist()} are not "
                             f"lattice sites of region {spec.region!r}")
        # a particle carries the mass of the lattice cells it stands in
        mass[dem] = particle_mass[dem]
    return (bi, bj, bk), overlap, mass


def same_corners(conn: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Which cells of ``conn`` have the corners of a row of ``wanted`` (rows
    sorted), in any order: sorted rows matched by one np.unique, not a Python
    set of tuples (19 s of a 2.27 M-DOF bar's set-up)."""
    if conn.shape[1] != wanted.shape[1] or not len(wanted):
        return np.zeros(len(conn), bool)
    hit = np.isin(conn.min(axis=1), wanted[:, 0])      # the lowest corner first: candidates
    cand = np.sort(conn[hit], axis=1)
    _, inv = np.unique(np.concatenate([wanted, cand]), axis=0, return_inverse=True)
    inv = inv.ravel()
    known = np.zeros(inv.max() + 1, bool)
    known[inv[:len(wanted)]] = True
    hit[hit] = known[inv[len(wanted):]]
    return hit


def build(scene, reach: int = 1, store=None) -> ContinuumArrays:
    """The continuum model; ``reach``: external layers of dem partitions (lattice
    extent).  It carries the notes of reading its mesh (duplicates removed,
    entities reoriented), which the run logs."""
    store = store if store is not None else model_data.ModelData()
    mesh = store.read(scene.model)
    arrays = initial.apply(_build(scene, mesh, reach, store), scene, mesh)
    arrays = prescribed.apply(arrays, scene, mesh)
    return dataclasses.replace(arrays, notes=mesh.notes) if mesh.notes else arrays


def _build(scene, mesh, reach, store):
    spec = scene.model
    shells = spec.material.kind == "shell" or spec.shells
    if shells and scene.heat is not None:
        raise SceneError("heat: models with shells carry no heat (conduction needs plane or "
                         "solid cells)")
    if spec.material.kind == "shell":
        return ContinuumArrays(**shell_model.build(scene, mesh))
    dim = mesh.dim
    mat = elastic(spec.material, spec.integration, spec.hourglass)
    zone = None
    if spec.lattice is not None and spec.lattice.transition:
        zone = store.transition(spec, mesh)
    cells, mass = [], np.zeros(len(mesh.points))
    for fam, conn, Ke, me in group_matrices(mesh, spec.body, mat, "model.body",
                                            only=None if zone is None else zone.fe_cells):
        cells.append((fam, conn, Ke))
        mass += nodal(me, conn, len(mesh.points))
    if spec.shells:
        return ContinuumArrays(**shell_model.build_mixed(scene, mesh, cells, mass))
    if zone is not None:
        arrays = _with_zone(scene, mesh, zone, cells, mass + zone.node_mass)
        return _with_heat(arrays, scene, mesh, zone.points)
    fixed = fixed_dofs(scene, mesh, len(mesh.points), dim)
    loads = load_list(scene, mesh, dim, dim)
    n = len(mesh.points) * dim
    bonds, overlap = (), ()
    if spec.lattice is not None:
        bonds, overlap, mass = attach_lattice(scene, mesh, mass, cells, reach)
    lat = spec.lattice
    arrays = ContinuumArrays(dof=dim, points=mesh.points, mass=mass, cells=cells, fixed=fixed,
                             loads=tuple(loads), u0=np.zeros(n), v0=np.zeros(n),
                             material_D=mat.D(),
                             lattice=Lattice(bonds=bonds, overlap_cells=overlap,
                                             geometry=lat.geometry,
                                             break_strain=lat.break_strain,
                                             weibull=weibull_of(lat)) if lat else None,
                             contact=contact_of(lat) if lat else None)
    return _with_heat(arrays, scene, mesh)


def _with_heat(arrays, scene, mesh, particles=None):
    """The model with its conduction model (scene key ``heat``), if any."""
    if scene.heat is None:
        return arrays
    return dataclasses.replace(arrays, heat=heat.build(scene, mesh, particles, arrays.n_nodes))


def break_strain_of(lat, zone):
    """Each bond's critical strain: ``break_strain``, or with ``strength:
    packing`` that times the random packing's strain concentration (so the
    packing's first bond breaks at break_strain of uniaxial strain)."""
    if lat.strength != "packing":
        return lat.break_strain
    return lat.break_strain * zone.concentration       # validated: kind random, break_strain


def weibull_of(lat):
    """(modulus, seed) of ``model.lattice``'s strength spread, or None."""
    return None if lat.weibull_modulus is None else (lat.weibull_modulus, lat.seed)


def shear_of(lat):
    """(shear_ratio, tan friction_angle) of breakable beam bonds, or None."""
    if lat.bond != "beam" or lat.break_strain is None:
        return None
    ratio = 1.0 if lat.shear_ratio is None else lat.shear_ratio
    return ratio, float(np.tan(np.radians(lat.friction_angle or 0.0)))


def contact_of(lat, zone=None, n_nodes=0):
    """The :class:`solver.laws.ContactSettings` of ``model.lattice.contact``
    (its law object built from the registry), defaults filled, or None.  A
    random packing with a radius spread (``zone``, a transition band of
    ``n_nodes`` model nodes) and no ``radius`` given: every core particle
    touches at its own radius (``radii``), the largest standing for all
    where one radius is asked (the search's reach, the step bound)."""
    c = lat.contact
    if c is None:
        return None
    radius = c.radius if c.radius is not None else 0.5 * lat.spacing
    radii = None
    if c.radius is None and zone is not None and zone.radii is not None and \
            np.ptp(zone.radii) > 0:
        radii = np.full(n_nodes, radius)
        radii[zone.core_ids] = zone.radii
        radius = float(zone.radii.max())
    return ContactSettings(law=CONTACT_LAWS[c.law](c.stiffness), radius=radius,
                           skin=c.skin if c.skin is not None else 0.3 * radius,
                           damping_ratio=c.damping_ratio, friction=c.friction,
                           tangential_damping_ratio=c.tangential_damping_ratio,
                           history=c.friction_model == "history",
                           tangential_stiffness=c.tangential_stiffness,
                           rolling_friction=c.rolling_friction or 0.0, radii=radii)


def _dilatation(zone, n_nodes):
    """The volumetric term of the core particles (None without one)."""
    if zone.dilatation is None:
        return None
    c = np.zeros(n_nodes)
    c[zone.n_mesh:] = zone.dilatation
    bi, bj, _ = zone.bonds
    return dilatation.Dilatation(c, dilatation.counts(bi, bj, n_nodes))


INERTIA = {2: 0.5, 3: 0.4}     # a rotating particle's rotary inertia / m r^2: disc, sphere


def _with_zone(scene, mesh, zone, cells, mass):
    """The model of a transition band: mesh nodes, then the core particles."""
    dim = mesh.dim
    band_nodes = np.unique(np.concatenate([c.ravel() for c in zone.band_cells.values()]))
    massless = band_nodes[mass[band_nodes] <= 0]
    if massless.size:
        node = int(massless[0])
        raise SceneError(f"model.lattice.transition: band node {node} at "
                         f"{mesh.points[node].tolist()} carries no mass: no particle of its "
                         f"cells weighs on it ({massless.size} such nodes); refine the lattice "
                         "or coarsen the band")
    n_nodes = zone.n_mesh + zone.n_core
    lat = scene.model.lattice
    dof, rotary = dim, None
    if zone.bending is not None:           # rotating particles: (u, theta) on every node
        dof = ROTATING_DOFS[dim]
        cells = [(fam, conn, shell_model.Padded(Ke, fam.n_nodes, dim, dof))
                 for fam, conn, Ke in cells]
        rotary = np.ones(n_nodes)            # (mesh nodes: never used, their rotation is fixed)
        rotary[zone.n_mesh:] = INERTIA[dim] * zone.mass * zone.radii ** 2
    fixed = fixed_dofs(scene, mesh, n_nodes, dof)
    if rotary is not None:
        fixed.reshape(n_nodes, dof)[:zone.n_mesh, dim:] = True
    n = n_nodes * dof
    return ContinuumArrays(dof=dof, points=np.concatenate([mesh.points, zone.points]),
                           mass=np.concatenate([mass, zone.mass]), cells=cells,
                           fixed=fixed, loads=tuple(load_list(scene, mesh, dof, dim)),
                           u0=np.zeros(n), v0=np.zeros(n), rotary=rotary,
                           material_D=elastic(scene.model.material).D(),
                           lattice=Lattice(bonds=zone.bonds, carried=zone.blocks,
                                           geometry=lat.geometry,
                                           break_strain=break_strain_of(lat, zone),
                                           weibull=weibull_of(lat), bending=zone.bending,
                                           shear=shear_of(lat),
                                           dilatation=_dilatation(zone, n_nodes)),
                           contact=contact_of(lat, zone, n_nodes), zone=zone)

