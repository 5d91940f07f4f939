"""Scene sections that describe the structure: networks (inline, generated or
from a file) and continua (a gmsh mesh, a material, a lattice).

Part of the scene schema (:mod:`solver.scene` re-exports every name).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


from solver.laws import BOND_GEOMETRIES, CONTACT_LAWS
from solver.scene import time_function
from solver.scene.schema import convert, fail, key, shown, tagged

GROUND = -1  # node id of the fixed end of a spring


def _node_ref(value, path):
    if value == "ground":
        return GROUND
    if isinstance(value, bool) or not isinstance(value, int):
        fail(path, f"expected a node id or 'ground', got {shown(value)}")
    if value < 0:
        fail(path, f"node id must be non-negative, got {value}")
    return value


@dataclass(frozen=True)
class Spring:
    """A linear spring between two nodes (or a node and the ground)."""

    i: int
    j: int
    stiffness: float


def _springs(value, path):
    if not isinstance(value, list):
        fail(path, f"expected a list of [node_i, node_j, stiffness], got {shown(value)}")
    out = []
    for n, item in enumerate(value):
        p = f"{path}[{n}]"
        if not isinstance(item, list) or len(item) != 3:
            fail(p, f"expected [node_i, node_j, stiffness], got {shown(item)}")
        i, j = _node_ref(item[0], p), _node_ref(item[1], p)
        if i == j:
            fail(p, f"spring connects {shown(item[0])} to itself")
        k = convert(float, item[2], p, {"positive": True})
        out.append(Spring(i, j, k))
    return tuple(out)


MAX_NODES = 10**8          # generated networks: beyond this memory, not the model, is the limit


@dataclass(frozen=True)
class ChainGenerator:
    name: Literal["chain"] = key("generator name")
    n: int = key("number of masses", positive=True)
    mass: float = key("mass of every node [kg]", positive=True)
    stiffness: float = key("stiffness of every spring [N/m]", positive=True)
    left: Literal["fixed", "free"] = key("left end tied to the ground or free", "fixed")
    right: Literal["fixed", "free"] = key("right end tied to the ground or free", "free")

    def validate(self, path):
        if self.n > MAX_NODES:
            fail(f"{path}.n", f"{self.n} masses: at most {MAX_NODES:.0e} are generated")


@dataclass(frozen=True)
class MetamaterialGenerator:
    name: Literal["metamaterial"] = key("generator name")
    M: int = key("shells before the resonator band", nonnegative=True)
    N: int = key("shells carrying a resonator", nonnegative=True)
    Q: int = key("shells after the resonator band", nonnegative=True)
    shell_mass: float = key("m_s [kg]", positive=True)
    resonator_mass: float = key("m_v [kg]", positive=True)
    k_n: float = key("shell-shell spring and right-end ground spring [N/m]", positive=True)
    k_s: float = key("shell-resonator spring [N/m]", positive=True)
    resonators: bool = key("false: the plain chain of shells (Li et al. 2023, Fig. 8)", True)

    def validate(self, path):
        if self.M + self.N + self.Q < 1:
            fail(path, "M + N + Q must be at least 1")
        if self.M + 2 * self.N + self.Q > MAX_NODES:
            fail(path, f"M + 2 N + Q = {self.M + 2 * self.N + self.Q} masses: at most "
                 f"{MAX_NODES:.0e} are generated")


_generator = tagged("name", {"chain": ChainGenerator, "metamaterial": MetamaterialGenerator})


@dataclass(frozen=True)
class NetworkModel:
    """Lumped masses joined by linear springs, one DOF per node: given as
    masses + springs, a generator, or a file."""

    kind: Literal["network"] = key("model kind")
    masses: tuple[float, ...] | None = key(
        "mass of each node [kg]; the node ids are the list positions", None, positive=True)
    springs: tuple[Spring, ...] | None = key(
        "springs as [node_i, node_j, stiffness N/m]; 'ground' is a fixed end", None,
        parse=_springs, choices_doc="list of [node|ground, node|ground, float]")
    generator: ChainGenerator | MetamaterialGenerator | None = key(
        "a named generator with its parameters (instead of masses and springs)", None,
        parse=_generator, choices_doc="mapping with name: chain | metamaterial",
        variants=(ChainGenerator, MetamaterialGenerator))
    file: str | None = key("NPZ or HDF5 file with arrays mass, spring_i, spring_j (-1 = ground), "
                           "stiffness; path relative to the scene file", None)

    def validate(self, path):
        if (self.masses is None) != (self.springs is None):
            fail(f"{path}.{'springs' if self.springs is None else 'masses'}",
                 "masses and springs are given together")
        given = [k for k in ("masses", "generator", "file") if getattr(self, k) is not None]
        if len(given) != 1:
            fail(path, "give exactly one of masses + springs, generator, file "
                 f"({', '.join(given) or 'none'} given)")
        if self.file is not None and not self.file.strip():
            fail(f"{path}.file", f"{shown(self.file)}: needs a file name")


@dataclass(frozen=True)
class Material:
    E: float = key("Young's modulus [Pa]", positive=True)
    nu: float = key("Poisson's ratio", nonnegative=True)
    rho: float = key("density [kg/m^3]", positive=True)
    kind: Literal["plane_stress", "plane_strain", "solid", "shell"] = key(
        "plane_stress (2D, with thickness), plane_strain (2D), solid (3D), or shell (a surface "
        "of triangles and/or quadrilaterals in 3D, 6 DOFs per node: ux uy uz rx ry rz; "
        "docs/shells.md)", "solid")
    thickness: float | None = key("thickness [m]: out of plane (plane_stress, default 1) or "
                                  "the shell wall's (shell, required; more than 1e-6 x the "
                                  "shell's smallest element edge, where bending ~ t^3 and the "
                                  "rotary inertia lose all scale)", None, positive=True)
    membrane: Literal["allman", "andes", "cst"] = key(
        "shell: the triangles' membrane: allman (Allman 1984), andes (Felippa's optimal ANDES "
        "membrane: bends well in plane) or cst (constant strain: no locking on curved or warped "
        "thin shells); quadrilaterals are MITC4 either way; docs/shells.md measures them on "
        "the obstacle course", "allman")
    drilling: float = key("shell: the drilling-rotation penalty gamma / G of the membrane "
                          "(Hughes-Brezzi; allman, cst and quadrilaterals, not andes); cst and "
                          "quadrilaterals also take drilling x D / k per corner (D = E t^3 / "
                          "(12 (1 - nu^2)), k corners)", 1e-2, positive=True)
    tie: float = key("shells on a solid body (model.shells): the penalty gamma / G tying a shell "
                     "node's rotation to the rotation curl(u)/2 of the solid elements around it",
                     1.0, positive=True)
    rotary_inertia: Literal["physical", "scaled"] = key(
        "shell: each node's rotary inertia, a third of rho t^3/12 A per element (physical) or "
        "of rho t A (t^2 + A)/12 (scaled: the rotations never set the explicit step)",
        "physical")

    def validate(self, path):
        if not self.nu < 0.5:
            fail(f"{path}.nu", f"{self.nu} must be below 0.5")
        if self.kind == "shell" and self.thickness is None:
            fail(f"{path}.thickness", "a shell needs its wall thickness")

    @property
    def depth(self) -> float:
        """Out-of-plane depth of the body: the thickness in plane stress
        (default 1 m), 1 m otherwise."""
        return self.thickness if self.kind == "plane_stress" and self.thickness is not None \
            else 1.0


DOF_NAMES = ("ux", "uy", "uz", "rx", "ry", "rz")


@dataclass(frozen=True)
class Constraint:
    group: str = key("physical group (node set) whose chosen DOFs stay zero")
    dofs: tuple[str, ...] = key("DOFs held: ux, uy, uz (translations), rx, ry, rz (shell "
                                "rotations), e.g. [uy, rx, rz] on a symmetry plane y = 0")

    def validate(self, path):
        bad = [d for d in self.dofs if d not in DOF_NAMES]
        if bad or not self.dofs:
            fail(f"{path}.dofs", f"{list(self.dofs)}: each DOF is one of {', '.join(DOF_NAMES)}")


@dataclass(frozen=True)
class Prescribed:
    group: str = key("physical group (node set) whose chosen DOFs move as given")
    dofs: tuple[str, ...] = key("DOFs driven: ux, uy, uz (translations), rx, ry, rz (shell "
                                "rotations); each takes the same motion")
    quantity: Literal["velocity", "displacement"] = key(
        "what the time function gives: velocity [m/s] (the displacement is its integral from "
        "t = 0, so the DOFs start where they are) or displacement [m] (the velocity is its "
        "derivative)")
    kind: Literal["sine", "half_sine", "rectangular", "tabulated"] = key(
        "time function, as loads[].kind: sine A sin(omega t); half_sine A sin(pi (t-start)/"
        "duration) on [start, start+duration]; rectangular A on [start, start+duration) "
        "(velocity only); tabulated piecewise linear through table, end values held "
        "(a constant velocity V: table [[0, V], [1, V]])")
    amplitude: float = key("A [m/s or m] (sine, half_sine, rectangular)", 1.0)
    omega: float | None = key("angular frequency [rad/s] (sine)", None, positive=True)
    duration: float | None = key("pulse length [s] (half_sine, rectangular)", None, positive=True)
    start: float = key("pulse start [s] (half_sine, rectangular)", 0.0, nonnegative=True)
    table: tuple[tuple[float, ...], ...] | None = key(
        "[[t, value], ...] with increasing t (tabulated)", None)

    def validate(self, path):
        bad = [d for d in self.dofs if d not in DOF_NAMES]
        if bad or not self.dofs:
            fail(f"{path}.dofs", f"{list(self.dofs)}: each DOF is one of {', '.join(DOF_NAMES)}")
        if len(set(self.dofs)) != len(self.dofs):
            fail(f"{path}.dofs", f"{list(self.dofs)} names a DOF twice")
        time_function.check(self, path, "motion")
        if self.quantity == "displacement" and self.kind == "rectangular":
            fail(f"{path}.kind", "a rectangular displacement jumps (its velocity would be "
                 "infinite): prescribe quantity velocity, or a tabulated displacement ramp")


def registered(registry):
    """A ``parse`` hook: the value is a name of ``registry`` (solver.laws)."""
    def parse_name(value, path):
        if not isinstance(value, str) or value not in registry:
            fail(path, f"{shown(value)} is not one of {', '.join(registry)}")
        return value
    return parse_name


@dataclass(frozen=True)
class ContactSpec:
    stiffness: float = key("normal contact stiffness of two touching particles: k_n [N/m] "
                           "(law linear, f = k_n d) or k_h [N/m^1.5] (law hertz, f = k_h d^1.5), "
                           "d the overlap", positive=True)
    law: str = key(
        "linear: spring k_n d; hertz: k_h d^1.5 (the step bound takes its tangent at an "
        "overlap of 0.1 x radius)", "linear", parse=registered(CONTACT_LAWS),
        choices_doc=CONTACT_LAWS.choices)
    damping_ratio: float = key(
        "normal dashpot c = 2 zeta sqrt(k m*) of each contact (zeta this ratio, k the "
        "contact's tangent stiffness, m* the pair's reduced mass): a spring-dashpot; its "
        "dissipation enters the energy audit", 0.0, nonnegative=True)
    friction: float = key(
        "Coulomb friction coefficient mu (0: none); how the tangential force arises: "
        "friction_model", 0.0, nonnegative=True)
    friction_model: Literal["viscous", "history"] = key(
        "viscous: the tangential force opposes the sliding velocity v_t with min(mu f_n, c_t "
        "|v_t|), c_t = 2 zeta_t sqrt(k m*), no shear history (LAMMPS's gran/hooke); history: "
        "a tangential spring k_t on the shear displacement accumulated since the contact began, "
        "kept per pair across neighbour-list rebuilds, ranks and restarts, capped at mu f_n "
        "(Coulomb sliding), with a dashpot c_t = 2 zeta_t sqrt(k_t m*) while it sticks "
        "(Cundall-Strack; LAMMPS's gran/hooke/history)", "viscous")
    tangential_stiffness: float = key(
        "friction_model history: k_t / k, k the contact's normal tangent stiffness (LAMMPS's "
        "default 2/7)", 2.0 / 7.0, positive=True)
    tangential_damping_ratio: float = key(
        "zeta_t of the tangential dashpot (friction > 0): the viscous friction's "
        "regularisation, or the dashpot beside the history spring", 0.5, nonnegative=True)
    rolling_friction: float | None = key(
        "rolling resistance mu_r of rotating particles (bond: beam, friction_model history): "
        "a rolling spring k_r = k_t R*^2 (R* = radius / 2) on the pair's relative rotation "
        "since the contact began (3D: its part across the contact normal; twisting is free), "
        "its moment at most mu_r R* f_n (beyond it the pair rolls, the energy the cap takes "
        "dissipated); default none", None, positive=True)
    radius: float | None = key("particle radius [m], one for all; default half the lattice "
                               "spacing (bonded neighbours just touch at rest), and with a random "
                               "packing's radius_spread each particle's own radius (a pair "
                               "touches closer than r_i + r_j)", None, positive=True)
    skin: float | None = key("neighbour-list skin [m]: the pair search is rebuilt when a particle "
                             "has moved half of it; default 0.3 x radius", None, positive=True)

    def validate(self, path):
        if self.rolling_friction is not None and self.friction_model != "history":
            fail(f"{path}.rolling_friction", "is a spring kept per contact beside the shear "
                 "spring: give friction_model: history")
        if self.friction_model == "history" and not self.friction:
            fail(f"{path}.friction_model", "history is the sticking and sliding of friction: "
                 "give friction > 0")
        if self.friction_model == "viscous" and not self.tangential_damping_ratio and \
                self.friction:
            fail(f"{path}.tangential_damping_ratio", "friction_model viscous needs it > 0 (the "
                 "friction force is c_t |v_t| below mu f_n)")


@dataclass(frozen=True)
class LatticeSpec:
    region: str = key("physical group (cells) filled with the bonded lattice")
    spacing: float = key("lattice spacing a [m]; without a transition band the mesh must have a "
                         "node at every lattice site of the region and one spacing around it; "
                         "with one, the lattice is laid from the band's lower corner and every "
                         "width along each axis (band and region together, the band on either "
                         "side, the region) must be a whole number of spacings (to 1e-6), so "
                         "that it ends on the band's far edge: otherwise refused, naming the "
                         "nearest spacings that tile", positive=True)
    E: float | None = key("Young's modulus of the lattice [Pa] when it differs from the model's "
                          "material (a stiffer or softer DEM region); default: model.material.E",
                          None, positive=True)
    geometry: str = key(
        "linear: bonds act on the small-strain displacement (one assembled operator); "
        "nonlinear: each bond pulls along its current direction with its current length "
        "(large rotations exert no force), needed for break_strain", "linear",
        parse=registered(BOND_GEOMETRIES), choices_doc=BOND_GEOMETRIES.choices)
    break_strain: float | None = key(
        "nonlinear bonds break for good when their strain (L - L0)/L0 exceeds this (beams: "
        "the strain of their most stretched fibre, axial plus bending); the released energy "
        "and every break (time, place, strain; beams: mode) are recorded", None,
        positive=True)
    weibull_modulus: float | None = key(
        "Weibull modulus m of the bonds' strengths: each bond breaks at break_strain x w, w "
        "Weibull-distributed with shape m and mean 1 (m 3-10 for rocks and ceramics; larger: "
        "less spread), drawn from its particles' ids and seed (the same on any ranks); "
        "default: every bond at break_strain", None, positive=True)
    seed: int = key("seed of the strength spread (weibull_modulus) and of the random packing "
                    "(kind random)", 0, nonnegative=True)
    contact: ContactSpec | None = key(
        "contact of particles that share no live bond (linear spring k_n on the overlap of "
        "spheres); needs geometry: nonlinear", None)
    transition: str | None = key(
        "physical group of the transition band (Zhang et al. 2009): one layer of coarse cells around "
        "the region that the lattice overlaps; its particles move with their cell (shape-function "
        "weights), their bond forces and masses go to the cell's nodes, and the region's cells "
        "only give its shape (see docs/transition.md)", None)
    kind: Literal["square", "random"] = key(
        "square: square lattice with diagonal bonds in 2D (nu = 1/3 plane stress, 1/4 plane "
        "strain), simple cubic with face diagonals in 3D (nu = 1/4); random: a seeded "
        "Poisson-disc packing of particles of radius spacing/2 (radius_spread), bonded to their "
        "Delaunay neighbours within gap, E calibrated on a uniaxial test of the packing (central "
        "bonds give nu about 0.33 plane stress, 0.25 plane strain and 3D; a larger nu adds a "
        "volumetric many-body term calibrated to it, up to about 0.47 in 3D; needs transition; "
        "docs/bonds.md)", "square")
    strength: Literal["bond", "packing"] = key(
        "what break_strain is: bond, each bond's critical strain; packing (kind random), the "
        "packing's uniaxial strain at its first break: each bond breaks at break_strain x the "
        "calibration's strain concentration (about 1.5, logged), so a random packing is as "
        "strong as the square lattice with the same break_strain", "bond")
    gap: float | None = key(
        "kind random: two particles are bonded when their surfaces are at most gap x their mean "
        "diameter apart (Delaunay neighbours); default 1.0", None, nonnegative=True)
    radius_spread: float | None = key(
        "kind random: radii uniform in spacing/2 x (1 -+ radius_spread), below 1; default 0",
        None, nonnegative=True)
    shear_ratio: float | None = key(
        "bond: beam with break_strain: a beam breaks in shear when its shear stress |V|/A "
        "exceeds shear_ratio x its tensile strength E_b break_strain (plus the friction "
        "term); default 1 (Potyondy & Cundall's parallel bond, docs/bonds.md)", None,
        positive=True)
    friction_angle: float | None = key(
        "bond: beam with break_strain: Mohr-Coulomb friction angle [degrees] of the bonds' "
        "shear strength, which grows by the compressive stress across the bond x tan(angle); "
        "default 0", None, nonnegative=True)
    bond: Literal["central", "beam"] = key(
        "central: bonds carry a normal force only (the packing's own nu); beam (kind "
        "random, geometry nonlinear): particles rotate (2D: one more DOF each, inertia "
        "1/2 m r^2; 3D: three, inertia 2/5 m r^2, orientations kept as quaternions) and "
        "bonds are co-rotational "
        "beams carrying normal and shear force, bending (and in 3D twisting) moments, "
        "calibrated to E and nu (nu from 0 to the central value), breaking in tension or "
        "shear with break_strain (docs/bonds.md); contact turns them",
        "central")

    @property
    def bond_gap(self) -> float:
        return 1.0 if self.gap is None else self.gap

    @property
    def spread(self) -> float:
        return 0.0 if self.radius_spread is None else self.radius_spread

    def validate(self, path):
        if self.contact is not None and not BOND_GEOMETRIES[self.geometry].current:
            fail(f"{path}.contact", "needs geometry: nonlinear (contact follows the particles' "
                 "current positions)")
        if self.weibull_modulus is not None and self.break_strain is None:
            fail(f"{path}.weibull_modulus", "spreads the bonds' strengths around break_strain: "
                 "give break_strain")
        for name in ("gap", "radius_spread"):
            if getattr(self, name) is not None and self.kind != "random":
                fail(f"{path}.{name}", "sets up a random packing: give kind: random")
        if self.seed and self.weibull_modulus is None and self.kind != "random":
            fail(f"{path}.seed", "seeds the strength spread and the random packing: give "
                 "weibull_modulus or kind: random")
        if self.spread >= 1.0:
            fail(f"{path}.radius_spread", f"{self.spread:g}: radii spacing/2 x (1 -+ spread) "
                 "need a spread below 1")
        if self.strength == "packing" and (self.kind != "random" or self.break_strain is None):
            fail(f"{path}.strength", "packing scales break_strain by a random packing's strain "
                 "concentration: give kind: random and break_strain")
        if self.kind == "random" and not self.transition:
            fail(f"{path}.kind", "random packings are laid in a transition band and its region "
                 "(give transition); without one every particle is a mesh node")
        if self.bond == "beam":
            if self.kind != "random" or not BOND_GEOMETRIES[self.geometry].current:
                fail(f"{path}.bond", "beam bonds join the particles of a random packing from "
                     "their current configuration: give kind: random and geometry: nonlinear")
        if self.contact is not None and self.contact.rolling_friction is not None and \
                self.bond != "beam":
            fail(f"{path}.contact.rolling_friction", "resists the rolling of rotating "
                 "particles: give bond: beam")
        for name in ("shear_ratio", "friction_angle"):
            if getattr(self, name) is not None and (self.bond != "beam" or
                                                    self.break_strain is None):
                fail(f"{path}.{name}", "sets the shear strength of breakable beam bonds: give "
                     "bond: beam and break_strain")
        if self.friction_angle is not None and not 0.0 <= self.friction_angle < 90.0:
            fail(f"{path}.friction_angle", f"{self.friction_angle:g} degrees: give an angle in "
                 "[0, 90)")
        if self.break_strain is not None and not BOND_GEOMETRIES[self.geometry].breakable:
            fail(f"{path}.break_strain", "needs geometry: nonlinear (a small-strain bond does not "
                 "know its current length)")


@dataclass(frozen=True)
class ShellPart:
    group: str = key("physical surface group of shell triangles and/or quadrilaterals joined "
                     "to the solid body")
    thickness: float = key("the shell wall's thickness [m]; more than 1e-6 x the surface's "
                           "smallest element edge", positive=True)


@dataclass(frozen=True)
class Section:
    group: str = key("physical surface group: cells of the shell body (also in model.body's "
                     "group) that take this thickness")
    thickness: float = key("their wall thickness [m]; more than 1e-6 x the group's smallest "
                           "element edge", positive=True)


@dataclass(frozen=True)
class ContinuumModel:
    """An elastic body meshed with gmsh; nodes carry dim DOFs."""

    kind: Literal["continuum"] = key("model kind")
    mesh: str = key("gmsh .geo (meshed on reading) or .msh file, relative to the scene file")
    material: Material = key("linear elastic material")
    body: str = key("physical group of the body's cells", "solid")
    integration: Literal["full", "selective", "reduced"] = key(
        "quad4 and hex8 cells: full (2x2 / 2x2x2 Gauss points), selective (the volumetric "
        "lambda term at the cell centre, the shear terms full: Hughes' selective reduced "
        "integration, B-bar for isotropic materials: no volumetric locking as nu -> 0.5), or "
        "reduced (everything at the centre, one point, with Flanagan-Belytschko hourglass "
        "stiffness, model.hourglass); tri3 and tet4 take one point either way", "full")
    hourglass: float = key(
        "integration reduced: the hourglass stiffness c of quad4 and hex8 cells, the "
        "hourglass modes' stiffness c 2 mu V |grad N|^2 / dim (Flanagan-Belytschko 1981, "
        "stiffness form, on the shear modulus: no volumetric locking); 0 < c <= 1", 0.1,
        positive=True)
    fixed: tuple[str, ...] = key("physical groups whose nodes are fixed (all components); a "
                                 "partition must keep a free DOF (one whose every DOF is held "
                                 "has nothing to step and is refused)", ())
    constraints: tuple[Constraint, ...] = key("chosen DOFs held at zero on physical groups "
                                              "(symmetry planes, supports); with model.fixed "
                                              "they must leave each partition a free DOF", ())
    prescribed: tuple[Prescribed, ...] = key(
        "DOFs of physical groups moved with a given velocity or displacement in time (a "
        "grip, a shaker, an imposed settlement): held out of the solve like model.fixed, "
        "their motion set each step; the reaction's work counts as external work "
        "(docs/guide/prescribed.md)", ())
    shells: tuple[ShellPart, ...] = key(
        "solid bodies: shell surfaces (triangles and/or quadrilaterals, the body's material) "
        "sharing nodes with the "
        "solid; every node then has 6 DOFs, a shell node on the solid has its rotation tied to "
        "the solid's (docs/shells.md, \"Shells and solids\")", ())
    sections: tuple[Section, ...] = key(
        "shell bodies: a thickness per group of the body's cells (the rest keep "
        "material.thickness); a cell in two sections is refused", ())
    lattice: LatticeSpec | None = key("bonded DEM lattice for dem partitions", None)
    mesh_parameters: dict[str, float] = key("numbers defined before the .geo is read (the .geo "
                                            "keeps its default with If (!Exists(a)) ...), "
                                            "e.g. {a: 4.0e-4}", {})

    def validate(self, path):
        if not self.mesh.endswith((".geo", ".msh")):
            fail(f"{path}.mesh", f"{self.mesh}: expected a .geo or .msh file")
        if self.shells and self.material.kind != "solid":
            fail(f"{path}.shells", f"shell surfaces join a solid body (material kind solid), "
                 f"not {self.material.kind}")
        if self.hourglass > 1.0:
            fail(f"{path}.hourglass", f"{self.hourglass} is out of range: 0 < hourglass <= 1 (a "
                 "fraction of the cell's own stiffness; 0.05-0.15 is usual)")
        if self.hourglass != 0.1 and self.integration != "reduced":
            fail(f"{path}.hourglass", f"is for integration: reduced (this model integrates "
                 f"{self.integration})")
        if self.sections and self.material.kind != "shell":
            fail(f"{path}.sections", f"sections give a shell body's groups their thickness; a "
                 f"{self.material.kind} body has none (shells on a solid: model.shells[].thickness)")
        if self.shells and self.lattice is not None:
            fail(f"{path}.lattice", "a model with shells has no lattice")
        if self.material.kind == "shell" and self.lattice is not None:
            fail(f"{path}.lattice", "shell models have no lattice (a dem region needs a plane or "
                 "solid body)")


parse_model = tagged("kind", {"network": NetworkModel, "continuum": ContinuumModel})


def parse_node_set(value, path):
    """Node ids as a list of ids and {range: [first, end)} items, or one range."""
    items = [value] if isinstance(value, dict) else value
    if not isinstance(items, list):
        fail(path, f"expected a list of node ids or ranges, got {shown(value)}")
    out = []
    for n, item in enumerate(items):
        p = f"{path}[{n}]"
        if isinstance(item, dict):
            if set(item) != {"range"}:
                fail(p, f"a node range is {{range: [first, end]}}, got {shown(item)}")
            r = item["range"]
            if (not isinstance(r, list) or len(r) != 2 or
                    any(isinstance(x, bool) or not isinstance(x, int) for x in r) or not 0 <= r[0] < r[1]):
                fail(f"{p}.range", f"expected [first, end] with 0 <= first < end, got {shown(r)}")
            out.extend(range(r[0], r[1]))
        elif isinstance(item, int) and not isinstance(item, bool) and item >= 0:
            out.append(item)
        else:
            fail(p, f"expected a node id or {{range: [first, end]}}, got {shown(item)}")
    return tuple(out)
