"""Fields for ParaView: XDMF time series written with meshio.

``output.fields: {every: N}`` writes, every N system steps, the body mesh with
point data displacement and velocity (3 components, z = 0 in 2D) and cell
data stress (averaged over the cell) as XDMF's ``Tensor6``, the symmetric
tensor's upper triangle row by row: (xx, xy, xz, yy, yz, zz), which ParaView
and VTK read; 2D bodies give the 3D tensor (zz = 0 in plane stress,
nu (xx + yy) in plane strain)
to ``<output stem>_fields.xdmf``, and the DEM particles (nodes owned by dem partitions) as
a vertex mesh with the same point data (and ``damage``, the fraction of its
bonds a particle has lost, when bonds can break) to ``<output stem>_particles.xdmf``;
with ``heat`` both carry the temperature.  With breakable bonds a run that writes
fields also writes ``<output stem>_cracks.xdmf``: every broken bond at its midpoint
with the time it broke (:func:`write_cracks`).  Both
share one time axis, so one ParaView session opens them together.  Values are
gathered to rank 0, which writes.

Frames are written at t = 0, every N system steps and at the state the run
ended in (the end time, or where a failed or interrupted run stopped), so the
last frame is always the final state.  Each XDMF holds one temporal
collection and nothing else (:func:`one_collection`): VTK's XDMF reader
(ParaView, pyvista) opens it as one time series, without a static mesh block
drawn over the result.
"""
from __future__ import annotations

import contextlib
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import h5py

from solver.driver.observers import Observer
from solver.model.elements import elastic, quadrature, strain_matrix, FAMILIES
from solver.model.shell import faces


def _open(xdmf: str):
    """A meshio TimeSeriesWriter whose .h5 sits beside ``xdmf`` (meshio opens it
    relative to the working directory, so enter it from the file's directory)."""
    from meshio.xdmf import TimeSeriesWriter  # lazy: meshio loads only where fields are written
    with contextlib.chdir(Path(xdmf).parent):
        return TimeSeriesWriter(xdmf).__enter__()


def tensor6(voigt: np.ndarray, kind: str, nu: float) -> np.ndarray:
    """Stress in our Voigt order (3D xx, yy, zz, yz, xz, xy; 2D xx, yy, xy) as
    XDMF Tensor6 (xx, xy, xz, yy, yz, zz)."""
    if voigt.shape[1] == 6:
        return voigt[:, [0, 5, 4, 1, 3, 2]]
    xx, yy, xy = voigt.T
    zz = nu * (xx + yy) if kind == "plane_strain" else np.zeros_like(xx)
    zero = np.zeros_like(xx)
    return np.stack([xx, xy, zero, yy, zero, zz], axis=1)


class FieldWriter(Observer):
    def __init__(self, scene, mdl, parts, comm, tag: str = "", heating=None):
        self.comm = comm
        self.parts = parts
        self.heating = heating
        self.every = scene.output.fields.every
        self.dof = mdl.dof
        self.dim = mdl.points.shape[1]
        self.shell = mdl.shells is not None      # 6 DOFs: u and rotations
        self.rotating = mdl.rotary is not None   # particles: u_x, u_y, theta; 3D: u, theta
        self.n = mdl.n_nodes
        self.writers = []
        self.n_open = 0
        self.last = None                # the time of the last frame written
        if comm.rank != 0:
            return
        base = Path(scene.output_file).resolve().with_suffix("")
        base.parent.mkdir(parents=True, exist_ok=True)
        # meshio puts the heavy data in <stem>.h5 beside each .xdmf: keep clear of ours
        self.files = [f"{base}{tag}_fields.xdmf", f"{base}{tag}_particles.xdmf"]
        points = np.zeros((self.n, 3))
        points[:, :mdl.points.shape[1]] = mdl.points
        self.points = points
        # the FE cells, and a transition band's cells (their stress is that of
        # the displacement they interpolate for their particles)
        blocks = [(fam, conn) for fam, conn, _ in mdl.cells]
        if mdl.zone is not None:
            blocks += [(FAMILIES[name], conn) for name, conn in mdl.zone.band_cells.items()]
        self.cells = [(fam.meshio, conn) for fam, conn in blocks       # each family's
                      if fam.meshio is not None]                        # meshio cell name
        # shells: membrane forces, moments and the faces' von Mises stress per
        # triangle (NaN on the solid cells of a model with both)
        self.shell_blocks = [Ke if fam.rotations else None
                             for fam, _, Ke in mdl.cells if fam.meshio is not None] \
            if self.shell else []
        self.stress_ops = []
        material = scene.model.material
        self.kind, self.nu = material.kind, material.nu
        D = self.D = elastic(material).D()
        for fam, conn in ([] if self.shell else blocks):   # u_e -> cell-averaged stress
            _, dNdx, _ = quadrature(fam, mdl.points[conn])
            self.stress_ops.append((conn, np.einsum("st,eqtj->esj", D, strain_matrix(dNdx)) /
                                    dNdx.shape[1]))
        dem = [p for p in scene.partitions if p.method == "dem"]
        self.particles = np.sort(np.concatenate(
            [np.asarray(p.nodes, dtype=np.int64) for p in dem] or [np.zeros(0, np.int64)]))
        mesh_w = _open(self.files[0])
        mesh_w.write_points_cells(points, self.cells)
        self.writers = [mesh_w]
        if dem and self.particles.size:
            part_w = _open(self.files[1])
            part_w.write_points_cells(points[self.particles],
                                      [("vertex", np.arange(self.particles.size)[:, None])])
            self.writers.append(part_w)
        self.n_open = len(self.writers)

    def after_step(self, step: int, t: float) -> None:
        """Observer hook: a frame every ``every`` system steps."""
        if step % self.every == 0:
            self.write(t)

    def finish(self, step: int, t: float) -> None:
        """Observer hook: the last frame is the state the run ended in."""
        self.write_final(t)

    def write(self, t: float):
        """A frame of the current state at time ``t`` (collective)."""
        self.last = t
        local = [(p.layout.owned, p.U[:p.n_own].reshape(-1, self.dof),
                  p.V[:p.n_own].reshape(-1, self.dof), p.force.rotation_vectors())
                 for p in self.parts]
        damage = [(p.layout.owned, p.force.damage()) for p in self.parts
                  if p.force.break_strain is not None]
        chunks = self.comm.gather((local, damage), root=0) if self.comm.size > 1 else \
            [(local, damage)]
        if self.comm.rank != 0:
            return
        width = max(self.dof, 3)
        u, v = np.zeros((self.n, width)), np.zeros((self.n, width))
        broken = np.zeros(self.n) if any(d for _, d in chunks) else None
        for chunk, dmg in chunks:
            for nodes, uu, vv, turned in chunk:
                u[nodes, :self.dof] = uu
                v[nodes, :self.dof] = vv
                if turned is not None:       # 3D particles: their orientations' rotation vectors
                    u[nodes[:len(turned)], 3:6] = turned
            for nodes, frac in dmg:
                broken[nodes] = frac
        flat = u[:, :self.dim].ravel()
        stress = [tensor6(np.einsum("esj,ej->es", op, flat[(conn[:, :, None] * self.dim +
                                                             np.arange(self.dim)).reshape(len(conn), -1)])
                          - self._thermal(conn), self.kind, self.nu)
                  for conn, op in self.stress_ops]
        point = {"displacement": u[:, :3], "velocity": v[:, :3]}
        if self.shell:
            point["rotation"] = u[:, 3:6]
        elif self.rotating and self.dim == 3:     # rotation vectors
            point.update(rotation=u[:, 3:6], angular_velocity=v[:, 3:6])
        elif self.rotating:                  # theta about z, then no third component
            point = {"displacement": np.pad(u[:, :2], ((0, 0), (0, 1))),
                     "velocity": np.pad(v[:, :2], ((0, 0), (0, 1))),
                     "rotation": u[:, 2].copy(), "angular_velocity": v[:, 2].copy()}
        if self.heating is not None:                 # every rank holds the same temperatures
            point["temperature"] = self.heating.T_node
        cell = {"stress": stress} if stress else {}
        if self.shell_blocks:
            cell.update(self._resultants(u))
        self.writers[0].write_data(t, point_data=point, cell_data=cell or None)
        if len(self.writers) > 1:
            data = {name: value[self.particles] for name, value in point.items()}
            if broken is not None:           # breakable bonds: the fraction each particle lost
                data["damage"] = broken[self.particles]
            self.writers[1].write_data(t, point_data=data)

    def write_final(self, t: float):
        """The state the run ended in at time ``t``, unless that frame is written
        already (collective)."""
        if self.last != t:
            self.write(t)

    def _resultants(self, u) -> dict:
        """membrane_force [N/m], moment [N m/m], the stresses (xx, yy, xy) at the
        top (+z of the cell frame), middle and bottom surfaces, sigma = N / t
        -+ 6 M / t^2 [Pa], and von_mises [Pa] (the larger face's) of every shell
        cell (solid cells: NaN)."""
        out = {name: [] for name in ("membrane_force", "moment", "stress_top", "stress_middle",
                                     "stress_bottom", "von_mises")}
        for (_, conn), Ke in zip(self.cells, self.shell_blocks):
            if Ke is None:
                nan = np.full((len(conn), 3), np.nan)
                parts = (nan, nan, nan, nan, nan, nan[:, 0])
            else:
                N, M, vm = Ke.resultants(u[conn].reshape(len(conn), 6 * conn.shape[1]))
                parts = (N, M, *faces(N, M, Ke.material.thickness), vm)
            for name, value in zip(out, parts):
                out[name].append(value)
        return out

    def _thermal(self, conn):
        """D eps_th of cells ``conn`` at their mean temperature (0 without heat)."""
        if self.heating is None:
            return 0.0
        spec = self.heating.spec
        dT = self.heating.T_node[conn].mean(axis=1) - spec.initial
        m = np.zeros(self.D.shape[0])
        m[:self.dim] = 1.0
        return spec.expansion * dT[:, None] * (self.D @ m)[None, :]

    def written(self) -> list[str]:
        """The files written: each XDMF and the HDF5 file meshio keeps beside it."""
        out = []
        for xdmf in self.files[:self.n_open]:
            out += [xdmf, str(Path(xdmf).with_suffix(".h5"))]
        return out

    def close(self):
        for w in self.writers:
            w.__exit__(None, None, None)
        if self.writers:
            for xdmf in self.files[:self.n_open]:
                one_collection(xdmf)
                name_datasets(xdmf)
        self.writers = []


def write_cracks(output_file: str, broken: np.ndarray, dim: int) -> list[str]:
    """The broken bonds as a point cloud for ParaView, ``<output stem>_cracks.xdmf``:
    one vertex per bond at its midpoint when it broke, with point data time,
    strain, critical strain and temperature (NaN without heat); beams also
    their mode (1 tension, 2 shear) and the energy they held."""
    import meshio  # lazy: meshio loads only where fields are written
    xdmf = Path(output_file).resolve().with_suffix("")
    xdmf = Path(f"{xdmf}_cracks.xdmf")
    pts = np.zeros((len(broken), 3))
    pts[:, :dim] = broken[:, 1:1 + dim]
    data = {name: broken[:, col] for name, col in
            (("time", 0), ("strain", 1 + dim), ("critical_strain", 2 + dim),
             ("temperature", 3 + dim))}
    if broken.shape[1] == 8 + dim:           # beams: the mode (1 tension, 2 shear) and energy
        data.update(mode=broken[:, 4 + dim], energy=broken[:, 5 + dim])
    with contextlib.chdir(xdmf.parent):
        meshio.write(xdmf.name, meshio.Mesh(pts, [("vertex", np.arange(len(pts))[:, None])],
                                            point_data=data))
    return [str(xdmf), str(xdmf.with_suffix(".h5"))]


XINCLUDE = "http://www.w3.org/2003/XInclude"


def one_collection(xdmf: str):
    """Rewrite meshio's time series ``xdmf`` as one temporal collection.

    meshio writes the mesh as a static top-level grid beside the collection,
    which VTK's reader shows as a second block (zero displacement at every
    time, drawn over the result).  Here the first time step's grid holds the
    Geometry and Topology, every later one includes them from it by XInclude
    (the heavy data are written once), and the Domain holds the collection
    only."""
    ET.register_namespace("xi", XINCLUDE)
    tree = ET.parse(xdmf)
    domain = tree.getroot().find("Domain")
    grids = domain.findall("Grid")
    collection = next(g for g in grids if g.get("GridType") == "Collection")
    mesh = next((g for g in grids if g.get("GridType") == "Uniform"), None)
    if mesh is None:                                 # already one collection
        return
    domain.remove(mesh)
    collection.set("Name", Path(xdmf).stem)
    steps = collection.findall("Grid")
    include = f"{{{XINCLUDE}}}include"
    pointer = "xpointer(/Xdmf/Domain/Grid/Grid[1]/*[self::Topology or self::Geometry])"
    for i, step in enumerate(steps):
        step.set("Name", f"step{i}")
        step.set("GridType", "Uniform")
        inc = step.find(include)
        if i == 0:
            at = list(step).index(inc)
            step.remove(inc)
            for j, item in enumerate(mesh.findall("Geometry") + mesh.findall("Topology")):
                step.insert(at + j, item)
        else:
            inc.set("xpointer", pointer)
    tree.write(xdmf, xml_declaration=True, encoding="utf-8")


def name_datasets(xdmf: str):
    """Give meshio's anonymous datasets (data0, data1, ...) in the HDF5 file
    beside ``xdmf`` the names the XDMF gives them: attribute ``name``
    (points, cells, displacement, velocity, stress) and, for fields, ``time``
    and ``center`` (Node or Cell)."""
    labels = {}
    for grid in ET.parse(xdmf).getroot().iter("Grid"):
        time = grid.find("Time")
        for tag, name in (("Geometry", "points"), ("Topology", "cells")):
            for node in grid.findall(tag):
                for item in node.iter("DataItem"):
                    labels[item.text.split(":/")[-1]] = {"name": name}
        for attr in grid.findall("Attribute"):
            item = attr.find("DataItem")
            label = {"name": attr.get("Name"), "center": attr.get("Center")}
            if time is not None:
                label["time"] = float(time.get("Value"))
            labels[item.text.split(":/")[-1]] = label
    with h5py.File(Path(xdmf).with_suffix(".h5"), "r+") as f:
        for dataset, label in labels.items():
            if dataset in f:
                f[dataset].attrs.update(label)
