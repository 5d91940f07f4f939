"""The scene file: YAML parsed once into typed, validated, frozen objects.

Every key is declared here with its type, default and documentation
(``python -m solver keys`` prints them; docs/scene.md lists them).  Nothing
downstream reads raw dictionaries.  Cross-section checks (node ids in range,
each node owned by exactly one partition, step ratios that divide the system
step) run in :meth:`Scene.validate`; the keys that refer to the mesh or the
network are checked when the scene is bound to its model data
(:func:`solver.model.binding.bind`, called by ``load``), before any work.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Literal

from solver.scene import expression, registry, time_function
from solver.scene.schema import fail, key, shown
from solver.scene.heat_spec import HeatSpec
from solver.scene.model_spec import ContinuumModel, NetworkModel, parse_model, parse_node_set


@dataclass(frozen=True)
class LevelSettings:
    max_ratio: int = key("partitions: auto: the largest step ratio of a level (its step "
                         "max_ratio x time.dt)", 8, positive=True)
    ratios: Literal["powers", "integers"] = key(
        "partitions: auto: the ratios a level may take: powers (1, 2, 4, ... up to max_ratio, "
        "which must then be a power of two) or integers (the divisors of max_ratio)", "powers")
    buffer: int = key("partitions: auto: element layers around a finer level that step with "
                      "it (the coarser kicks then land where the finer level's fast modes have "
                      "died out: no resonance on the measured cases, docs/guide/levels.md)", 2,
                      nonnegative=True)

    def validate(self, path):
        if self.ratios == "powers" and self.max_ratio & (self.max_ratio - 1):
            fail(f"{path}.max_ratio", f"{self.max_ratio} is not a power of two (ratios: powers); "
                 "use a power of two or ratios: integers")


@dataclass(frozen=True)
class MassScaling:
    dt: float = key("the stable step every element is raised to [s]: an element whose bound "
                    "step is below it gets its own mass scaled by (dt / step)^2 (docs/guide/"
                    "levels.md)", positive=True)
    max_added: float = key("refuse a target that adds more than this fraction of the model's "
                           "mass", 0.05, positive=True)


AUTO = "auto"


def parse_step(value, path):
    """``time.dt``: a positive number of seconds, or auto."""
    if value == AUTO:
        return AUTO
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        fail(path, f"expected a number or auto, got {shown(value)}")
    if not math.isfinite(value) or value <= 0:
        fail(path, f"must be positive, got {value}")
    return float(value)


@dataclass(frozen=True)
class Time:
    end: float = key("end time of the run [s]: a whole number of system steps (time.dt x the "
                     "largest partition ratio; to a relative 1e-9 and at most 1e-3 of a step, "
                     "so 0.1 with steps of 1e-3 is 100); the run ends exactly there, and any "
                     "other end is refused, naming the two nearest whole-step ends",
                     positive=True)
    dt: float | Literal["auto"] | None = key(
        "base step [s]; a partition steps ratio*dt.  auto (with partitions: auto): safety x "
        "the critical step of the finest level, lowered so that end is a whole number of "
        "system steps.  Required, except for analysis: static (which takes no step)", None,
        parse=lambda value, path: parse_step(value, path), choices_doc="float | auto")
    safety: float = key("partitions: auto: a level's step is at most safety x the bound of "
                        "its elements' stable steps; time.dt: auto takes safety x the finest "
                        "level's critical step", 0.9, positive=True)
    levels: LevelSettings = key("partitions: auto: the step ratios of the levels",
                                LevelSettings())
    mass_scaling: MassScaling | None = key(
        "add mass to the elements whose stable step is below a target (as LS-DYNA's DT2MS); "
        "the added mass is reported per level and in total", None)

    def validate(self, path):
        if self.safety > 1:
            fail(f"{path}.safety", f"{self.safety:g} is above 1: a step beyond the stable one")


NAME = re.compile(r"^[A-Za-z][A-Za-z0-9]*$")
# scene and probe names become file names and HDF5 groups: no path separators
LABEL = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.+-]{0,99}$")
MAX_SYSTEM_STEPS = 10**9   # a probe history is 16 bytes per system step
END_TOLERANCE = 1e-9       # time.end / system step within this (relative; at most 1e-3 of a
                           # step) of a whole number


def check_label(value, path, what):
    if not LABEL.match(value):
        fail(path, f"{shown(value)}: a {what} is 1-100 letters, digits, '_', '.', '+' or '-', not "
                   "starting with '.' or '-' (it names files and HDF5 groups)")


@dataclass(frozen=True)
class Partition:
    name: str = key("partition name; also the PETSc options prefix (name_)")
    method: Literal["fem", "dem"] = key("fem: sparse matrix partition; dem: particles and bonds")
    integrator: Literal["explicit", "implicit", "verlet"] = key(
        "explicit / implicit: Newmark predictor-corrector, explicit or implicit form (fem); "
        "verlet: velocity Verlet (dem)")
    ratio: int = key("this partition steps ratio*time.dt", positive=True)
    nodes: tuple[int, ...] = key("node ids owned by this partition: ids and {range: [first, end]} "
                                 "items (end excluded); or give group", (), parse=parse_node_set,
                                 choices_doc="list of int | {range: [int, int]}")
    group: str | None = key("continuum models: the physical group whose nodes this partition "
                            "owns (nodes shared with an earlier partition stay there)", None)
    beta: float = key("Newmark beta (explicit and implicit integrators)", 0.25, nonnegative=True)
    gamma: float = key("Newmark gamma (explicit and implicit integrators)", 0.5, positive=True)
    ranks: int | None = key("MPI ranks serving this partition (default: the run's ranks shared "
                            "by cost, estimated or measured as balance says; those left "
                            "without a rank ride on the least loaded one; see "
                            "docs/guide/ranks.md)", None, positive=True)

    SUPPORTED = {("fem", "explicit"), ("fem", "implicit"), ("dem", "verlet")}

    def validate(self, path):
        if bool(self.nodes) == (self.group is not None):
            fail(f"{path}.nodes", "give either nodes or group")
        if not NAME.match(self.name):
            fail(f"{path}.name", f"{shown(self.name)} must be letters and digits, starting with a letter "
                 "(it becomes the PETSc options prefix)")
        if (self.method, self.integrator) not in self.SUPPORTED:
            ok = ", ".join(f"{m}+{i}" for m, i in sorted(self.SUPPORTED))
            fail(f"{path}.integrator", f"method {self.method} with integrator {self.integrator} "
                 f"is not supported (supported: {ok})")


def scheme_name(value, path):
    """``coupling.scheme``: a registered scheme's name (:mod:`solver.scene.registry`)."""
    names = registry.names()
    if value not in names:
        fail(path, f"{shown(value)} is not one of {', '.join(map(str, names))}")
    return value


def scheme_summaries() -> str:
    """The ``coupling.scheme`` key's documentation: every scheme's summary."""
    return "; ".join(f"{name}: {cls.summary}" for name, cls in registry.declared().items())


@dataclass(frozen=True)
class Coupling:
    scheme: str = key(scheme_summaries, "overlap", parse=scheme_name,
                      choices_doc=lambda: " | ".join(registry.names()))
    external: Literal["taylor", "layers", "literal"] = key(
        "external-data treatment: taylor (one layer following the Taylor predictor from the last "
        "exchange, default), layers (one layer per sub-step, integrated), literal (Li et al. 2023: one "
        "layer integrated by the partition's own scheme)", "taylor")
    band_motion: Literal["predictor", "linear", "velocity", "hold"] = key(
        "transition scheme: how band particles move between FE steps: predictor (the FE's own "
        "explicit path u + s v + s^2/2 a, which ends on the FE's next displacement; default), "
        "linear (straight from the FE's u_n to its u_n+1), "
        "velocity (u + s v: the node velocities of eq. 4 held), hold (positions held until the "
        "next FE step)", "predictor")


@dataclass(frozen=True)
class Load:
    kind: Literal["sine", "half_sine", "rectangular", "tabulated"] = key(
        "sine: A sin(omega t); half_sine: A sin(pi (t-start)/duration) on [start, start+duration], "
        "0 elsewhere; rectangular: A on [start, start+duration), 0 elsewhere (sudden load and "
        "unload); tabulated: piecewise linear through table, end values held")
    node: int | None = key("loaded node (or give group or at)", None, nonnegative=True)
    group: str | None = key("continuum models: physical group (edge in 2D, face in 3D; for "
                            "shells an edge [N/m] or a patch of the surface [N/m^2]) carrying "
                            "a traction: amplitude in N/m (2D) or N/m^2 (3D)", None)
    at: tuple[float, ...] | None = key(
        "continuum models: a point [m]; the nearest body node takes the load on its DOF "
        "component (as probes[].at snaps)", None)
    direction: tuple[float, ...] | None = key("group loads: traction direction (default "
                                              "[1, 0(, 0)], or the axis of component)", None)
    component: int | None = key(
        "node and at loads: DOF of the node (0 for networks; default 0); group loads: the "
        "traction's axis x, y (, z) = 0, 1 (, 2), instead of direction", None, nonnegative=True)
    pressure: bool = key(
        "group loads: a pressure, amplitude in N/m^2 (3D) or N/m (2D), pushing against each "
        "facet's normal: into the body on its faces (2D: edges), against a shell cell's "
        "node-order normal on a shell surface; instead of direction", False)
    amplitude: float = key("A [N] (sine, half_sine, rectangular; a tabulated load's table "
                           "holds its values)", 1.0)
    omega: float | None = key("angular frequency [rad/s] (sine)", None, positive=True)
    duration: float | None = key("pulse length [s] (half_sine, rectangular)", None, positive=True)
    start: float = key("pulse start [s] (half_sine, rectangular)", 0.0, nonnegative=True)
    table: tuple[tuple[float, ...], ...] | None = key("[[t, value], ...] with increasing t (tabulated)",
                                                      None)

    def validate(self, path):
        if sum(x is not None for x in (self.node, self.group, self.at)) != 1:
            fail(f"{path}.node", "give one of node, group or at")
        if self.direction is not None and not any(self.direction):
            fail(f"{path}.direction", f"{list(self.direction)} is the zero vector: a traction "
                 "needs a direction")
        if self.pressure and self.group is None:
            fail(f"{path}.pressure", "is for group loads (a pressure on faces or edges)")
        if self.pressure and (self.direction is not None or self.component is not None):
            fail(f"{path}.{'direction' if self.direction is not None else 'component'}",
                 "a pressure acts along each facet's normal: give no direction or component")
        if self.direction is not None and self.group is None:
            fail(f"{path}.direction", "is for group loads (tractions); a node or at load acts "
                 "on its DOF component")
        time_function.check(self, path, "load")


@dataclass(frozen=True)
class InitialMotion:
    group: str | None = key("physical group whose nodes start so (default: every node of the "
                            "model, lattice particles and transition-band particles included)",
                            None)
    velocity: tuple[float | str, ...] | None = key(
        "initial velocity [m/s], one entry per axis: a number or an expression of the node's "
        "position x, y, z [m] (docs/guide/initial.md), e.g. [\"-20 * (x < 0.05)\", 0]", None)
    displacement: tuple[float | str, ...] | None = key(
        "initial displacement [m], one entry per axis, as velocity", None)

    def validate(self, path):
        if self.velocity is None and self.displacement is None:
            fail(path, "give velocity or displacement (or both)")
        for name in ("velocity", "displacement"):
            for i, c in enumerate(getattr(self, name) or ()):
                if isinstance(c, str):
                    expression.check(c, f"{path}.{name}[{i}]")


@dataclass(frozen=True)
class Initial:
    displacement: dict[int, float] = key("network models: node -> initial displacement", {})
    velocity: dict[int, float] = key("network models: node -> initial velocity", {})
    motion: tuple[InitialMotion, ...] = key(
        "continuum models: initial velocity and displacement by group or by position, applied "
        "in order (a later entry overrides an earlier one on the nodes and axes it gives)", ())


@dataclass(frozen=True)
class Probe:
    name: str = key("probe name (HDF5 group /probes/<name>)")
    node: int | None = key("probed node (or give at)", None, nonnegative=True)
    at: tuple[float, ...] | None = key(
        "continuum models: a point [m]; the nearest node of the body's cells is probed (the "
        "log and the output give its coordinates and distance); a point farther from it than "
        "its cells reach is refused", None)
    component: int = key("DOF of the node: 0 for networks; x, y (, z) = 0, 1 (, 2) for "
                         "continua", 0, nonnegative=True)

    def validate(self, path):
        check_label(self.name, f"{path}.name", "probe name")


@dataclass(frozen=True)
class MonolithicReference:
    kind: Literal["monolithic"] = key("the same model as one partition with a fine step")
    dt: float = key("step of the reference run [s]; must divide the system step", positive=True)
    integrator: Literal["explicit", "verlet"] = key(
        "explicit: Newmark explicit (fem partition); verlet: velocity Verlet (dem partition)",
        "explicit")
    cache: bool = key("keep the reference history beside the output (.reference-cache/) and "
                      "reuse it when model, loads, probes and step are unchanged", True)


@dataclass(frozen=True)
class BarWaveReference:
    kind: Literal["bar_wave"] = key(
        "1D wave in a bar loaded at x = 0 (continuum models): speed sqrt(E/rho), particle "
        "velocity sigma/(rho c) with sigma = traction/thickness (2D) or traction (3D), valid "
        "until the first reflection from x = length reaches the probe")
    length: float = key("bar length [m] (where the first reflection starts)", positive=True)
    load: int = key("index of the load in loads (its time function is the incident pulse)", 0,
                    nonnegative=True)


@dataclass(frozen=True)
class Fields:
    every: int = key("system steps between field snapshots (the state at t = 0 and the state "
                     "the run ended in are written too)", positive=True)


@dataclass(frozen=True)
class Checkpoint:
    every: int = key("system steps between checkpoints: the whole run state goes into the "
                     "output file (atomically, status running); --restart FILE continues from it",
                     positive=True)


@dataclass(frozen=True)
class Output:
    file: str = key("HDF5 output path, relative to the scene file (--set: to the working "
                    "directory); default results/<name>.h5 beside the scene file")
    fields: Fields | None = key("continuum models: XDMF time series of the mesh fields "
                                "(<file stem>_fields.xdmf) and the DEM particles (<stem>_particles.xdmf) "
                                "for ParaView", None)
    energy_every: int | None = key(
        "system steps between energy samples and blow-up checks (default: at least 100 samples, at "
        "most ~2000, and one per 10 system steps or fewer once a run has 1000 of them)",
        None, positive=True)
    progress: float = key("seconds between progress lines on rank 0 (0: none)", 10.0,
                          nonnegative=True)
    checkpoint: Checkpoint | None = key("write the run state into the output file every so "
                                        "many system steps", None)

    def validate(self, path):
        if not self.file.strip() or self.file.endswith("/"):
            fail(f"{path}.file", f"{shown(self.file)}: needs a file name")


@dataclass(frozen=True)
class Damping:
    alpha: float = key("mass-proportional coefficient [1/s]", 0.0, nonnegative=True)
    beta: float = key("stiffness-proportional coefficient [s]", 0.0, nonnegative=True)

    @property
    def active(self) -> bool:
        return self.alpha > 0 or self.beta > 0

    def ratio(self, omega: float) -> float:
        """Damping ratio of a mode of frequency omega: 1/2 (alpha/omega + beta omega)."""
        return 0.5 * (self.alpha / omega + self.beta * omega) if omega > 0 else 0.0


@dataclass(frozen=True)
class Guard:
    stable_step: bool = key(
        "refuse, before stepping, explicit steps with omega_max*dt at or beyond the "
        "integrator's limit and a sub-cycled transition scheme whose damping.beta gives a "
        "damping ratio below 0.01 at the DEM's omega_max (docs/transition.md); false runs "
        "anyway with a warning, dropping both requirements", True)
    energy_bound: float = key(
        "stop when total energy exceeds this factor times (initial energy + largest |external "
        "work| so far)", 10.0, positive=True)
    max_displacement: float | None = key(
        "stop (output marked failed) when a node or particle has moved farther than this [m]: "
        "particles flying apart; default for continua: the body's largest extent", None,
        positive=True)


@dataclass(frozen=True)
class Scene:
    name: str = key("scene name")
    time: Time = key("time span and base step")
    model: NetworkModel | ContinuumModel = key(
        "the structure: kind network (masses and springs) or continuum (gmsh mesh)",
        parse=parse_model, choices_doc="mapping with kind: network | continuum",
        variants=(NetworkModel, ContinuumModel))
    partitions: tuple[Partition, ...] | Literal["auto"] = key(
        "partitions; each node is owned by exactly one.  auto: levels by element step "
        "(docs/guide/levels.md).  analysis: static needs none, or one fem partition", ())
    preload: Literal["none", "static"] = key(
        "static (continuum models without a lattice): start the dynamic run from the static "
        "state K u0 = f(0) under the loads at t = 0 and gravity, at rest: no settling needed "
        "(docs/guide/static.md)", "none")
    analysis: Literal["dynamic", "static"] = key(
        "dynamic: step in time from the initial state; static (continuum models): solve K u = "
        "f once, the loads at their value at time.end (KSP prefix static_; "
        "docs/guide/static.md)", "dynamic")
    balance: Literal["estimated", "measured"] = key(
        "how the ranks are shared among the partitions (docs/guide/ranks.md): by estimated "
        "cost (owned nonzeros x steps per system step) or by measured cost (each partition's "
        "wall per system step x its ranks, timed before the run over balance_steps system "
        "steps from the initial state; the run then starts from the initial state, so its "
        "answers are an estimated run's on the same ranks; nothing is timed where the ranks "
        "cannot change: 1 rank, 1 rank per partition, or partitions[].ranks given for all)",
        "estimated")
    balance_steps: int = key("balance measured: system steps timed (after one more to warm up)",
                             5, positive=True)
    coupling: Coupling = key("how partitions exchange", Coupling())
    loads: tuple[Load, ...] = key("external forces", ())
    initial: Initial = key("initial state (zero where not given)", Initial())
    gravity: tuple[float, ...] | None = key(
        "continuum models: a uniform body acceleration g [m/s^2], one entry per axis (e.g. "
        "[0, -9.81]): every node of every partition carries m g from t = 0, m its lumped mass "
        "there (docs/guide/initial.md)", None)
    damping: Damping = key("Rayleigh damping C = alpha M + beta K of every partition (bonds "
                           "included)", Damping())
    probes: tuple[Probe, ...] = key("recorded node histories", ())
    reference: Literal["none", "modal"] | MonolithicReference | BarWaveReference = key(
        "none; modal: exact solution of the network at the probe times; a monolithic run "
        "{kind: monolithic, dt, integrator}; or the 1D bar wave {kind: bar_wave, length}",
        "none", parse=None, choices_doc="none | modal | mapping",
        variants=(MonolithicReference, BarWaveReference))
    output: Output | None = key("output file; default results/<name>.h5", None)
    guard: Guard = key("stability and blow-up guards", Guard())
    heat: HeatSpec | None = key("continuum models: heat conduction, laser heating and thermal "
                                "expansion (docs/heat.md)", None)

    # --- derived -------------------------------------------------------
    @property
    def system_ratio(self) -> int:
        return max(p.ratio for p in self.partitions)

    @property
    def system_dt(self) -> float:
        return self.time.dt * self.system_ratio

    @property
    def scheme(self):
        """The class of ``coupling.scheme`` (:class:`solver.coupling.scheme.Scheme`):
        its facts and rules."""
        return registry.lookup(self.coupling.scheme)

    @property
    def n_system_steps(self) -> int:
        """time.end / system step, a whole number (checked in validate)."""
        return max(round(self.time.end / self.system_dt), 1)

    @property
    def output_file(self) -> str:
        return self.output.file if self.output else f"results/{self.name}.h5"

    def validate(self, path):
        """Checks of the configuration alone; keys that refer to the mesh or the
        network are checked when the scene is bound (:mod:`solver.model.binding`)."""
        continuum = self.model.kind == "continuum"
        check_label(self.name, "name", "scene name")
        if self.analysis == "static":
            if self.preload != "none":
                fail("preload", "is for dynamic runs (analysis static is the static state itself)")
            self._check_static(continuum)
            self._check_rest(continuum)
            return
        if self.time.dt is None:
            fail("time.dt", "required: the base step [s] (or auto with partitions: auto)")
        if self.preload == "static":
            self._check_preload(continuum)
        if self.partitions == AUTO or self.time.dt == AUTO:
            self._check_auto(continuum)
            if self.partitions == AUTO:
                self._check_rest(continuum)
                return
        if not self.partitions:
            fail("partitions", "at least one partition is needed")
        names = set()
        for p, part in enumerate(self.partitions):
            if continuum and part.method == "dem" and self.model.lattice is None:
                fail(f"partitions[{p}].method", "a dem partition on a continuum model needs "
                     "model.lattice")
            if part.group is not None and not continuum:
                fail(f"partitions[{p}].group", "groups name mesh regions: continuum models only")
            if part.name in names:
                fail(f"partitions[{p}].name", f"duplicate partition name {shown(part.name)}")
            names.add(part.name)
        self.scheme.validate(self)           # the coupling scheme's own rules
        big = self.system_ratio
        for p, part in enumerate(self.partitions):
            if big % part.ratio:
                fail(f"partitions[{p}].ratio", f"{part.ratio} does not divide the largest ratio {big}")
        self._check_end()
        self._check_rest(continuum)

    def _check_static(self, continuum):
        """``analysis: static``: one solve of the whole model's K u = f; what a
        dynamic run would step and exchange has no place in it."""
        if not continuum:
            fail("analysis", "static is for continuum models")
        if self.partitions == AUTO:
            fail("partitions", "auto levels a dynamic run; analysis static solves the whole "
                 "model at once: give one fem partition or none")
        if len(self.partitions) > 1:
            fail("partitions", f"analysis static solves the whole model at once: give one fem "
                 f"partition or none ({len(self.partitions)} given)")
        if self.partitions and self.partitions[0].method != "fem":
            fail("partitions[0].method", "analysis static solves the FE model: fem")
        for name, bad, why in (
                ("model.lattice", self.model.lattice is not None,
                 "a static solve takes the FE cells alone (bonds, contact and breakage are "
                 "dynamic)"),
                ("heat", self.heat is not None, "a static solve carries no temperature"),
                ("initial.motion", bool(self.initial.motion),
                 "a static solve starts from nothing and has no velocity"),
                ("reference", self.reference != "none", "a static solve has no reference run"),
                ("output.checkpoint", bool(self.output and self.output.checkpoint),
                 "a static solve has nothing to restart")):
            if bad:
                fail(name, f"not with analysis static: {why}")
        if self.time.dt == AUTO:
            fail("time.dt", "auto makes levels for a dynamic run; analysis static takes no "
                 "step (leave time.dt out)")

    def _check_preload(self, continuum):
        """``preload: static``: the whole FE model's static state starts the run."""
        if not continuum:
            fail("preload", "static is for continuum models")
        if self.model.lattice is not None:
            fail("preload", "static solves the FE model: a lattice's bonds would start out of "
                 "balance with it (settle a lattice under damping instead)")
        for i, entry in enumerate(self.initial.motion):
            if entry.displacement is not None:
                fail(f"initial.motion[{i}].displacement", "not with preload static (the "
                     "preload sets every displacement)")

    def _check_auto(self, continuum):
        """``partitions: auto`` and ``time.dt: auto``: what they need (the levels
        themselves are made when the model exists, solver.partitions.levels)."""
        if self.partitions != AUTO:
            fail("time.dt", "auto needs partitions: auto (hand-written partitions take a "
                 "time.dt in seconds)")
        if not self.scheme.levels:
            fail("coupling.scheme", f"partitions: auto makes one levelled partition, coupled "
                 f"within itself; {self.coupling.scheme} couples hand-written partitions "
                 "(leave coupling.scheme out)")
        if self.damping.active:
            fail("damping", "partitions: auto steps undamped levels; Rayleigh damping needs "
                 "hand-written partitions")
        if self.heat is not None:
            fail("heat", "partitions: auto levels linear elastic elements; heat needs "
                 "hand-written partitions")
        if continuum and self.model.lattice is not None:
            fail("partitions", "auto levels the elements of a continuum or a network; a "
                 "lattice (model.lattice) needs hand-written fem and dem partitions")
        if isinstance(self.reference, MonolithicReference):
            fail("reference", "partitions: auto: a monolithic reference needs a time.dt "
                 "the levels divide; run it as its own scene")
        if self.time.dt != AUTO:
            n = self.time.end / self.time.dt
            if abs(n - round(n)) > min(END_TOLERANCE * n, 1e-3) or n < 1 - END_TOLERANCE:
                fail("time.end", f"{self.time.end:.12g} s is {n:.12g} steps of time.dt "
                     f"{self.time.dt:.12g} s; partitions: auto needs a whole number (its "
                     "levels divide them)")
            if n > MAX_SYSTEM_STEPS:
                fail("time.end", f"{self.time.end:.12g} s is {n:.3g} steps of {self.time.dt:.12g} "
                     f"s; at most {MAX_SYSTEM_STEPS:.0e} are run")

    def _check_rest(self, continuum):
        for i, ld in enumerate(self.loads):
            if ld.group is not None and not continuum:
                fail(f"loads[{i}].group", "tractions on groups need a continuum model")
        seen = set()
        for i, probe in enumerate(self.probes):
            if (probe.node is None) == (probe.at is None):
                fail(f"probes[{i}].node", "give either node or at")
            if probe.at is not None and not continuum:
                fail(f"probes[{i}].at", "coordinates need a continuum model")
            if probe.name in seen:
                fail(f"probes[{i}].name", f"duplicate probe name {shown(probe.name)}")
            seen.add(probe.name)
        if self.heat is not None:
            self._check_heat(continuum)
        if self.output and self.output.fields and not continuum:
            fail("output.fields", "field output is for continuum models")
        if self.reference == "modal" and self.damping.active and self.loads:
            fail("reference", "the damped modal reference covers free vibration (no loads)")
        if continuum and self.reference == "modal":
            fail("reference", "modal references are for network models")
        if continuum and (self.initial.displacement or self.initial.velocity):
            kind = "displacement" if self.initial.displacement else "velocity"
            fail(f"initial.{kind}", "node -> value initial states are for network models; a "
                 "continuum starts moving by initial.motion (by group or by position)")
        if not continuum and self.initial.motion:
            fail("initial.motion", "is for continuum models (a network gives initial.velocity "
                 "and initial.displacement by node)")
        if self.gravity is not None and not continuum:
            fail("gravity", "is for continuum models (a network's nodes have no direction)")
        if isinstance(self.reference, BarWaveReference):
            if not continuum:
                fail("reference.kind", "bar_wave needs a continuum model")
            if self.reference.load >= len(self.loads) or self.loads[self.reference.load].group is None:
                fail("reference.load", f"{self.reference.load} is not a traction load")
        if isinstance(self.reference, MonolithicReference):
            ratio = self.system_dt / self.reference.dt
            if abs(ratio - round(ratio)) > 1e-6 * ratio:
                fail("reference.dt", f"{self.reference.dt} does not divide the system step "
                     f"{self.system_dt}")
            if continuum and self.reference.integrator != "explicit":
                fail("reference.integrator", "continuum references run the explicit fem integrator")

    def _check_end(self):
        """A run ends on a system step: time.end must be a whole number of them
        (to END_TOLERANCE, relative), or it would stop short without a word."""
        end, Dt = self.time.end, self.system_dt
        steps = end / Dt
        if steps < 1 - END_TOLERANCE:
            fail("time.end", f"{end:.12g} s is shorter than one system step ({Dt:.12g} s)")
        if steps > MAX_SYSTEM_STEPS:
            fail("time.end", f"{end:.12g} s is {steps:.3g} system steps of {Dt:.12g} s; at most "
                 f"{MAX_SYSTEM_STEPS:.0e} are run (histories are kept in memory)")
        if abs(steps - round(steps)) > min(END_TOLERANCE * steps, 1e-3):
            below, above = math.floor(steps), math.floor(steps) + 1
            fail("time.end", f"{end:.12g} s is {steps:.12g} system steps of {Dt:.12g} s (time.dt "
                 f"x ratio {self.system_ratio}); a run ends on a whole system step: use "
                 f"{below * Dt:.12g} ({below} step{'s' * (below != 1)}) or {above * Dt:.12g} "
                 f"({above} steps)")

    def _check_heat(self, continuum):
        if not continuum:
            fail("heat", "heat conduction needs a continuum model (a mesh to conduct on)")
        mat = self.model.material
        if mat.kind == "shell" or self.model.shells:
            fail("heat", "models with shells carry no heat (conduction needs plane or solid "
                 "cells)")
        if self.heat.laser is not None and mat.kind != "plane_stress":
            fail("heat.laser", f"needs model.material.kind plane_stress (a thin plate heated "
                 f"through its thickness), not {mat.kind}")
        lat = self.model.lattice
        if self.heat.melting is not None and (lat is None or lat.break_strain is None):
            fail("heat.melting", "weakens breakable bonds: needs model.lattice.break_strain")
