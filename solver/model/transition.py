"""Zhang et al.'s (2009) transition zone: a lattice whose outer particle layers sit inside
coarse FE cells (``model.lattice.transition``).

The mesh has three kinds of cells: the FE cells (the body without the two
groups below), the *band* (``lattice.transition``: one layer of coarse cells
around the DEM region) and the DEM *region* (``lattice.region``, whose cells
only give its shape).  Lattice sites are laid on the bounding box of band and
region and kept where they fall inside a band or region cell; a site in a band
cell is a *band particle*, the others are *core particles*.  Bonds and masses
are those of the lattice cells whose four (eight) corners are kept.

Core particles are model nodes (numbered after the mesh nodes) and belong to
the dem partitions.  Band particles are not nodes: each one moves with its
cell (eq. 4: u_p = sum_i N_i(xi_p) u_i), so a bond that touches a band
particle is an element on the cell's nodes.  With e the bond's unit vector
and g = T^T (-e, e) the bond direction carried to the element's nodes
through the interpolation T, its stiffness is k g g^T: the forces the bond
puts on its band particle go to the cell's nodes with the weights N_i
(eq. 3), and the bond's energy is exactly the lattice's.  Band node masses
are the weighted particle masses (eq. 5); the band cells themselves carry no
FE stiffness or mass (the particles are the material there, so nothing is
counted twice).  The band's density and stiffness are then the lattice's,
and the FE partition's critical step grows with the band cells' size.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from solver.errors import SceneError
from solver.model.embedding import (Embedding, find, flat_cells, local_coordinates,
                                    locate_in_cells)
from solver.model import calibration, dilatation, packing
from solver.model.elements import FAMILIES, volumes
from solver.model.lattice import cubic, square


class RankOneBonds:
    """Stiffness k g g^T of bonds carried to nodes (``g`` [n_el, nd]); blocks
    computed when asked, like :class:`solver.model.cell_blocks.CellStiffness`."""

    def __init__(self, conn, g, k, length):
        self.conn, self.g, self.k, self.length = conn, g, k, length

    def __len__(self) -> int:
        return len(self.conn)

    def __getitem__(self, idx) -> np.ndarray:
        g, k = self.g[idx], self.k[idx]
        return k[:, None, None] * g[:, :, None] * g[:, None, :]

    def subset(self, mask) -> "RankOneBonds":
        return RankOneBonds(self.conn[mask], self.g[mask], self.k[mask], self.length[mask])


class CarriedBeams:
    """Stiffness blocks [n, nd, nd] of beam bonds carried to nodes (T^T K T,
    the last node a core particle or not) with their rest separations ``d``
    [n, dim] (from the bond's first end to its second)."""

    def __init__(self, conn, blocks, d):
        self.conn, self.blocks, self.d = conn, blocks, d

    def __len__(self) -> int:
        return len(self.conn)

    def __getitem__(self, idx) -> np.ndarray:
        return self.blocks[idx]

    def subset(self, mask) -> "CarriedBeams":
        return CarriedBeams(self.conn[mask], self.blocks[mask], self.d[mask])


@dataclass(frozen=True)
class Transition:
    n_mesh: int
    points: np.ndarray          # [n_core, dim] core particles: model nodes n_mesh + i
    mass: np.ndarray            # [n_core]
    bonds: tuple                # (i, j, k) between core particles, model node ids
    blocks: list                # ("bond", conn, RankOneBonds) of bonds with a band end
    node_mass: np.ndarray       # [n_mesh] band particle masses on the nodes (eq. 5)
    band: Embedding             # band particles in the band cells (mesh node ids)
    band_points: np.ndarray
    band_mass: np.ndarray
    fe_cells: dict              # family -> conn: the body's cells outside band and region
    band_cells: dict            # family -> conn
    spacing: float
    packing: str | None = None  # what the random packing is (None: the regular lattice)
    concentration: float = 1.0  # the packing's largest bond strain per uniaxial strain (lattice: 1)
    bending: np.ndarray | None = None  # k_b of the core bonds (bond: beam), else None
    radii: np.ndarray | None = None    # [n_core] the core particles' radii (random packing)
    dilatation: np.ndarray | None = None   # [n_core] c of the volumetric term, else None

    @property
    def n_core(self) -> int:
        return len(self.points)

    @property
    def core_ids(self) -> np.ndarray:
        return self.n_mesh + np.arange(self.n_core)

    def describe(self) -> str:
        n_cells = sum(len(c) for c in self.band_cells.values())
        per = np.bincount(self.band.cell, minlength=n_cells)
        text = (f"transition zone: {n_cells} band cells holding {len(self.band_points)} band "
                f"particles ({per.min()}-{per.max()} per cell), {self.n_core} core particles, "
                f"{sum(len(c) for _, c, _ in self.blocks)} bonds carried to band nodes")
        return text if self.packing is None else f"{text}; {self.packing}"


def _keys(conn):
    """Order-free row keys of a connectivity (to compare cells between groups)."""
    s = np.sort(conn, axis=1)
    return np.ascontiguousarray(s).view([("", s.dtype)] * s.shape[1]).ravel()


def _without(cells: dict, *others: dict) -> dict:
    out = {}
    for fam, conn in cells.items():
        drop = np.zeros(len(conn), bool)
        for other in others:
            if fam in other and len(other[fam]):
                drop |= np.isin(_keys(conn), _keys(other[fam]))
        if (~drop).any():
            out[fam] = conn[~drop]
    return out


def _empty_cells(points, cells: dict, assigned, particles) -> np.ndarray:
    """Band cells (indices over the families in order) with no particle inside
    or on their boundary (a particle on a shared face is assigned to one cell
    only, so the unassigned cells are searched again on their own)."""
    n = sum(len(c) for c in cells.values())
    left = np.setdiff1d(np.arange(n), assigned)
    empty, offset = [], 0
    for fam, conn in cells.items():
        mine = left[(left >= offset) & (left < offset + len(conn))] - offset
        for c in mine:
            hit, _ = find(points, conn[c:c + 1], fam, particles)
            if not (hit >= 0).any():
                empty.append(offset + c)
        offset += len(conn)
    return np.asarray(empty, dtype=np.int64)


def _label(group, index: int) -> str:
    """'gmsh element <tag>' of cell ``index`` over the group's families in order."""
    for fam, conn in group.cells.items():
        if index < len(conn):
            tags = group.cell_tags.get(fam)
            return f"gmsh element {int(tags[index])}" if tags is not None else f"{fam} cell {index}"
        index -= len(conn)
    return f"cell {index}"


def build(spec, mesh) -> Transition:
    """The transition zone of continuum model ``spec`` on ``mesh``."""
    lat, mat = spec.lattice, spec.material
    key = "model.lattice.transition"
    body = mesh.group(spec.body, "model.body")
    region = mesh.group(lat.region, "model.lattice.region")
    band = mesh.group(lat.transition, key)
    for name, group in ((lat.region, region), (lat.transition, band)):
        if not group.cells or group.dim != mesh.dim:
            raise SceneError(f"{key}: group {name!r} must hold {mesh.dim}D cells")
    pts, dim, a = mesh.points, mesh.dim, lat.spacing
    fe_cells = _without(body.cells, band.cells, region.cells)
    _check_layer(mesh, fe_cells, region, band, lat)

    # lattice sites (or a random packing) on the bounding box of band and region
    nodes = np.unique(np.concatenate([band.nodes, region.nodes]))
    lo, hi = pts[nodes].min(axis=0), pts[nodes].max(axis=0)
    sites = (_random if lat.kind == "random" else _square)(spec, pts, band, region, lo, hi)
    points, mass, bi, bj, bk, band_cell, band_w, kept, note, concentration, kb, radii, bulk = sites
    is_band = kept & (band_cell >= 0)
    is_core = kept & ~is_band
    empty = _empty_cells(pts, band.cells, band_cell[is_band], points[is_band])
    if empty.size:
        what = (f"particle of the random packing (radius {a / 2:g} m; {empty.size} such "
                "cells); band cells must be large enough to hold particles" if note else
                f"particle of spacing {a:g} m ({empty.size} such cells); the band must "
                "overlap the lattice")
        raise SceneError(f"{key}: band cell {_label(band, int(empty[0]))} of group "
                         f"{lat.transition!r} holds no {what}")
    if not is_core.any():
        raise SceneError(f"model.lattice.region: no {'particle' if note else 'lattice site'} "
                         f"of spacing {a:g} m lies in region {lat.region!r} outside the band")
    if lat.kind != "random":
        _check_tiling(lat, pts[nodes], pts[region.nodes])

    n_mesh = len(pts)
    band_ids, core_ids = np.flatnonzero(is_band), np.flatnonzero(is_core)
    model_id = np.full(len(points), -1, dtype=np.int64)
    model_id[core_ids] = n_mesh + np.arange(core_ids.size)
    band_no = np.full(len(points), -1, dtype=np.int64)
    band_no[band_ids] = np.arange(band_ids.size)
    _, flat_conn = flat_cells(band.cells)
    b_nodes = flat_conn[band_cell[band_ids]]                        # [n_band, k]
    b_w = band_w[band_ids]
    emb = Embedding(band_cell[band_ids], b_nodes, b_w, np.zeros((band_ids.size, dim)))

    # bonds: core-core stay bonds; bonds with a band end become elements on nodes
    cc = is_core[bi] & is_core[bj]
    bonds = (model_id[bi[cc]], model_id[bj[cc]], bk[cc])
    ends = (bi, bj, bk, is_band, is_core, band_no, model_id, b_nodes, b_w)
    if kb is None:
        blocks = _carried_bonds(points, *ends)
    else:
        blocks = _carried_beams(points, *ends, kb,
                                _curls(pts, band.cells, band_cell[band_ids], points[band_ids]))
    node_mass = emb.to_nodes(mass[band_ids], n_mesh)
    return Transition(n_mesh, points[core_ids], mass[core_ids], bonds, blocks, node_mass,
                      emb, points[band_ids], mass[band_ids], fe_cells, dict(band.cells), a, note,
                      concentration, None if kb is None else kb[cc],
                      None if radii is None else radii[core_ids],
                      None if bulk is None else bulk * dilatation.weights(
                          radii[core_ids], bonds[0] - n_mesh, bonds[1] - n_mesh, dim, mat.depth))


def _carried_bonds(points, bi, bj, bk, is_band, is_core, band_no, model_id, b_nodes, b_w):
    """Block sets ("bond", conn, RankOneBonds) of the central bonds with a band
    end, on the nodes of their cells and their core particle (the last node):
    k g g^T, g the bond's direction carried through the weights N."""
    unit = points[bj] - points[bi]
    length = np.linalg.norm(unit, axis=1)
    unit /= length[:, None]
    blocks = []
    bb = is_band[bi] & is_band[bj]
    if bb.any():
        p, q, n = band_no[bi[bb]], band_no[bj[bb]], unit[bb]
        g = np.concatenate([-b_w[p][:, :, None] * n[:, None, :],
                            b_w[q][:, :, None] * n[:, None, :]], axis=1).reshape(bb.sum(), -1)
        conn = np.hstack([b_nodes[p], b_nodes[q]])
        blocks.append(("bond", conn, RankOneBonds(conn, g, bk[bb], length[bb])))
    for band_end, core_end, sign in ((bi, bj, 1.0), (bj, bi, -1.0)):
        m = is_band[band_end] & is_core[core_end]
        if m.any():
            p, n = band_no[band_end[m]], sign * unit[m]          # n from band to core
            g = np.concatenate([-b_w[p][:, :, None] * n[:, None, :], n[:, None, :]],
                               axis=1).reshape(m.sum(), -1)
            conn = np.hstack([b_nodes[p], model_id[core_end[m]][:, None]])
            blocks.append(("bond", conn, RankOneBonds(conn, g, bk[m], length[m])))
    return blocks


def _square(spec, pts, band, region, lo, hi):
    """The square (cubic) lattice's sites on the box [lo, hi], those inside a
    band or region cell kept, with the bonds and masses of the lattice cells
    whose corners are all kept."""
    lat, mat, dim, a = spec.lattice, spec.material, len(lo), spec.lattice.spacing
    shape = np.floor((hi - lo) / a + 1e-6).astype(int) + 1
    if np.prod(shape, dtype=float) > 5e7:
        raise SceneError(f"model.lattice.spacing: {a:g} m gives {np.prod(shape, dtype=float):.3g} "
                         "lattice sites on the region's bounding box (limit 5e7)")
    try:
        E = lat.E or mat.E
        grid = (square(lo, shape, a, E, mat.nu, mat.rho, mat.depth, mat.kind)
                if dim == 2 else cubic(lo, shape, a, E, mat.nu, mat.rho))
    except ValueError as e:
        raise SceneError(f"model.lattice: {e}") from None
    band_cell, band_w, kept = _inside(pts, band, region, grid.points)
    full = kept[grid.corners].all(axis=1)
    bi, bj, bk = grid.bonds(full)
    share = mat.rho * (mat.depth * a ** 2 / 4 if dim == 2 else a ** 3 / 8)
    mass = np.bincount(grid.corners[full].ravel(), minlength=len(grid.points)) * share
    kept &= mass > 0                               # a site outside every kept cell: no particle
    return grid.points, mass, bi, bj, bk, band_cell, band_w, kept, None, 1.0, None, None, None


def _inside(pts, band, region, particles):
    """(band cell or -1, weights in it, inside band or region) of each particle."""
    band_cell, band_w = locate_in_cells(pts, band.cells, particles)
    in_region = np.zeros(len(particles), bool)
    todo = np.flatnonzero(band_cell < 0)
    region_cell, _ = locate_in_cells(pts, region.cells, particles[todo])
    in_region[todo[region_cell >= 0]] = True
    return band_cell, band_w, (band_cell >= 0) | in_region


def _random(spec, pts, band, region, lo, hi):
    """A seeded Poisson-disc packing of the box [lo, hi] (:mod:`solver.model.packing`),
    the particles inside a band or region cell kept, bonded to their Delaunay
    neighbours within the gap, calibrated to E by a measured uniaxial test
    (:mod:`solver.model.calibration`); the band and region's mass shared in
    proportion to r^dim."""
    lat, mat, dim = spec.lattice, spec.material, len(lo)
    gap, spread = lat.bond_gap, lat.spread
    E = lat.E or mat.E
    try:
        points, radii = packing.poisson_disc(lo, hi, 0.5 * lat.spacing, spread, lat.seed)
    except ValueError as e:
        raise SceneError(f"model.lattice.spacing: {e}") from None
    band_cell, band_w, kept = _inside(pts, band, region, points)
    ids = np.flatnonzero(kept)
    i, j = packing.neighbour_pairs(points[ids], radii[ids], gap)
    bonded = np.zeros(ids.size, bool)
    bonded[i] = bonded[j] = True
    if not bonded.all():
        raise SceneError(f"model.lattice.gap: {gap:g} leaves {int((~bonded).sum())} of "
                         f"{ids.size} particles unbonded (none of their Delaunay neighbours "
                         "within the gap); give a larger gap")
    beam = lat.bond == "beam"
    psi = eta = 0.0
    start = time.perf_counter()
    try:
        bulk = not beam and _above(mat, dim, spread, gap, lat.seed)
        kappa, measured = calibration.calibrate(E, mat.nu, mat.kind, spread, gap, lat.seed,
                                                check=not beam and not bulk)
        if beam:
            kappa, psi, measured = calibration.calibrate_beams(E, mat.nu, mat.kind, spread, gap,
                                                               lat.seed)
        elif bulk:
            kappa, eta, measured = calibration.calibrate_bulk(E, mat.nu, mat.kind, spread, gap,
                                                              lat.seed)
    except calibration.Floppy as e:
        raise SceneError(f"model.lattice.gap: {e}") from None
    except ValueError as e:
        raise SceneError(f"model.lattice{'.bond' if beam else ''}: {e}") from None
    bk = packing.bond_stiffness(points[ids], radii[ids], i, j, E, mat.depth, kappa)
    kb = None
    if beam:
        kb = psi * bk * np.sum((points[ids][j] - points[ids][i]) ** 2, axis=1) / 12.0
    volume = sum(volumes(FAMILIES[fam], pts[conn]).sum()
                 for group in (band, region) for fam, conn in group.cells.items())
    mass = np.zeros(len(points))
    mass[ids] = packing.masses(radii[ids], dim, mat.rho * (mat.depth if dim == 2 else 1.0) * volume)
    nu = measured.nu / (1.0 + measured.nu) if mat.kind == "plane_strain" else measured.nu
    note = (f"random packing: {ids.size} particles (radius {0.5 * lat.spacing:g} m, spread "
            f"{spread:g}, seed {lat.seed}), {i.size} bonds (gap {gap:g}; "
            f"{2 * i.size / ids.size:.2f} per particle), E calibrated (bond factor {kappa:.4g}) "
            f"on {calibration.tests(measured)} ({time.perf_counter() - start:.1f} s), which "
            f"gives nu {nu:.3f}; its "
            f"most stretched bond carries {measured.concentration:.2f} x the applied strain")
    if beam:
        note += (f"; beam bonds (bending k_b = {psi:.4g} k L^2 / 12"
                 f"{', torsion k_t = k_b' if dim == 3 else ''}, calibrated to nu {mat.nu:g}), "
                 f"particles rotating with inertia {'1/2' if dim == 2 else '2/5'} m r^2")
    if eta:
        note += (f"; a volumetric term on every particle's bonds (c = {eta:.4g} kappa E V n / "
                 f"{dilatation.FULL[dim]:g}, "
                 f"calibrated to nu {mat.nu:g})")
    if lat.strength == "packing":
        note += (f"; bonds break at {measured.concentration:.3f} x break_strain (strength: "
                 "packing)")
    return (points, mass, ids[i], ids[j], bk, band_cell, band_w, kept, note,
            measured.concentration, kb, radii, eta * kappa * E or None)


def _above(mat, dim, spread, gap, seed) -> bool:
    """Whether nu lies above what the packing's central bonds represent by more
    than calibration.BULK_MIN (the volumetric term then makes up the rest)."""
    m = calibration.sampled(dim, float(spread), float(gap), int(seed))
    represents = m.nu / (1.0 + m.nu) if mat.kind == "plane_strain" else m.nu
    return mat.nu > represents + calibration.BULK_MIN


def _curls(pts, cells: dict, cell, particles) -> np.ndarray:
    """The rotation of the displacement field at each band particle as a map
    from its cell's nodal displacements, theta = 1/2 curl u = sum_a C_a u_a
    over the cell's nodes a: [n, k, 2] in 2D (theta = 1/2 (du_y/dx -
    du_x/dy), C_a = 1/2 (-dN_a/dy, dN_a/dx)), [n, k, 3, 3] in 3D (C_a =
    1/2 [grad N_a]x)."""
    fams, conn = flat_cells(cells)
    fams, k = np.asarray(fams), conn.shape[1]
    dim = pts.shape[1]
    out = np.zeros((len(particles), k, 2) if dim == 2 else (len(particles), k, 3, 3))
    for fam in set(fams[cell].tolist()):
        at = np.flatnonzero(fams[cell] == fam)
        X = pts[conn[cell[at]]][:, :FAMILIES[fam].n_nodes]
        xi = local_coordinates(fam, X, particles[at])
        _, dN = FAMILIES[fam].shape(xi)                          # [n, k, dim] dN/dxi
        J = np.einsum("nkd,nke->nde", X, dN)                      # dx/dxi
        g = np.einsum("nke,ned->nkd", dN, np.linalg.inv(J))       # dN/dx
        if dim == 2:
            out[at, :X.shape[1]] = 0.5 * np.stack([-g[..., 1], g[..., 0]], axis=-1)
            continue
        C = np.zeros(g.shape[:2] + (3, 3))
        C[..., 0, 1], C[..., 0, 2], C[..., 1, 2] = -g[..., 2], g[..., 1], -g[..., 0]
        out[at, :X.shape[1]] = 0.5 * (C - np.swapaxes(C, -1, -2))
    return out


def _carried_beams(points, bi, bj, bk, is_band, is_core, band_no, model_id, b_nodes, b_w, kb,
                   curl):
    """Block sets ("beam", conn, CarriedBeams) of the beam bonds with a band end,
    on the nodes of their cells (each with a rotating particle's DOFs: u and
    rotations the nodes do not use) and their core particle: T^T K T, K the
    bond's stiffness at rest (:func:`solver.model.calibration.beams_at_rest`)
    and T the map from the element's DOFs to the bond ends' (u, theta): a
    band particle moves with its cell (weights N) and turns with its
    displacement field's rotation (``curl``).  A band-core bond is oriented
    from its band end to its core particle, the element's last node (as the
    central bonds')."""
    flip = is_core[bi] & is_band[bj]
    bi, bj = np.where(flip, bj, bi), np.where(flip, bi, bj)
    d = points[bj] - points[bi]
    dim = d.shape[1]
    nd = calibration.ROTATING_DOFS[dim]
    K = calibration.beams_at_rest(d, bk, kb)
    k = b_nodes.shape[1]

    def band_rows(p):                                   # [n, nd, nd k]: (u, theta) of p
        T = np.zeros((len(p), nd, k, nd))
        for c in range(dim):
            T[:, c, :, c] = b_w[p]
        if dim == 2:
            T[:, 2, :, :2] = curl[p]
        else:
            T[:, 3:, :, :3] = np.transpose(curl[p], (0, 2, 1, 3))
        return T.reshape(len(p), nd, nd * k)

    out = []
    for m in (is_band[bi] & is_band[bj], is_band[bi] & is_core[bj]):
        if not m.any():
            continue
        n = int(m.sum())
        core = bool(is_core[bj[m][0]])
        Ti = band_rows(band_no[bi[m]])
        Tj = np.broadcast_to(np.eye(nd), (n, nd, nd)) if core else band_rows(band_no[bj[m]])
        T = np.zeros((n, 2 * nd, Ti.shape[2] + Tj.shape[2]))
        T[:, :nd, :Ti.shape[2]] = Ti
        T[:, nd:, Ti.shape[2]:] = Tj
        conn = np.hstack([b_nodes[band_no[bi[m]]],
                          model_id[bj[m]][:, None] if core else b_nodes[band_no[bj[m]]]])
        out.append(("beam", conn, CarriedBeams(conn, np.einsum("bri,brs,bsj->bij", T, K[m], T),
                                               d[m])))
    return out


TILE_TOLERANCE = 1e-6     # a width is a whole number of spacings to this (in spacings)


def _widths(zone_pts, region_pts) -> list[tuple[str, str, float]]:
    """(what, axis, width) along each axis: the zone (band and region
    together), the band below the region, the region, the band above it (in
    this order, each starting where a lattice line lies once the ones before
    it tile)."""
    lo, hi = zone_pts.min(axis=0), zone_pts.max(axis=0)
    rlo, rhi = region_pts.min(axis=0), region_pts.max(axis=0)
    out = []
    for d, axis in enumerate("xyz"[:len(lo)]):
        out += [("band and region together", axis, hi[d] - lo[d]),
                ("the band below the region", axis, rlo[d] - lo[d]),
                ("the region", axis, rhi[d] - rlo[d]),
                ("the band above the region", axis, hi[d] - rhi[d])]
    return out


def tiles(widths, a) -> bool:
    return all(abs(w / a - round(w / a)) <= TILE_TOLERANCE * max(1.0, w / a) for w in widths)


def tiling_spacings(widths, a) -> tuple[float | None, float | None]:
    """The spacings nearest ``a`` below and above it that tile every width:
    the smallest width divided by a whole number (None where none is found)."""
    base = min(widths)
    n0 = base / a
    below = next((base / n for n in range(max(1, int(np.ceil(n0 - 1e-9))), int(4 * n0) + 100)
                  if base / n < a and tiles(widths, base / n)), None)
    above = next((base / n for n in range(max(1, int(np.floor(n0 + 1e-9))), 0, -1)
                  if base / n > a and tiles(widths, base / n)), None)
    return below, above


def _check_tiling(lat, zone_pts, region_pts):
    """The lattice, laid from the zone's lower corner, must end on its upper
    corner and on the region's edges: every width of band and region (along
    each axis) a whole number of spacings.  Otherwise it stops short of the
    band's far edge (the DEM region loses mass, the interface reflects)."""
    a = lat.spacing
    widths = [(what, axis, w) for what, axis, w in _widths(zone_pts, region_pts)
              if w > TILE_TOLERANCE * a]
    bad = next(((what, axis, w) for what, axis, w in widths if not tiles([w], a)), None)
    if bad is None:
        return
    what, axis, w = bad
    below, above = tiling_spacings([x for _, _, x in widths], a)
    near = " or ".join(f"{x:.6g}" for x in (below, above) if x is not None) or "none near it"
    raise SceneError(f"model.lattice.spacing: {a:g} m does not tile the transition zone: "
                     f"{what} (band {lat.transition!r}, region {lat.region!r}) is {w:.6g} m "
                     f"wide in {axis}, {w / a:.4g} spacings, so the lattice stops "
                     f"{(w / a - np.floor(w / a + TILE_TOLERANCE)) * a:.3g} m short of its edge; "
                     f"spacings that tile every width: {near} m")


def _check_layer(mesh, fe_cells, region, band, lat):
    """The band must be a layer of cells between the region and the FE cells:
    no node of a region cell in an FE cell, every band cell touching the region."""
    key = "model.lattice.transition"
    region_nodes = np.zeros(len(mesh.points), bool)
    region_nodes[region.nodes] = True
    for fam, conn in fe_cells.items():
        touch = region_nodes[conn].any(axis=1)
        if touch.any():
            node = int(conn[touch][0][region_nodes[conn[touch][0]]][0])
            raise SceneError(f"{key}: band {lat.transition!r} does not separate region "
                             f"{lat.region!r} from the FE cells: mesh node {node} at "
                             f"{mesh.points[node].tolist()} is in both ({int(touch.sum())} FE "
                             "cells touch the region)")
    index = 0
    for fam, conn in band.cells.items():
        away = ~region_nodes[conn].any(axis=1)
        if away.any():
            raise SceneError(f"{key}: band cell {_label(band, index + int(np.flatnonzero(away)[0]))} "
                             f"of {lat.transition!r} does not touch region {lat.region!r}: the "
                             "band must be one layer of cells around the DEM region")
        index += len(conn)
    for fam in band.cells:
        if fam not in FAMILIES or FAMILIES[fam].dim != mesh.dim:
            raise SceneError(f"{key}: group {lat.transition!r} has {fam} cells; the band needs "
                             f"{mesh.dim}D cells")

