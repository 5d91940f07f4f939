"""Rotating particles with beam bonds in 3D scenes (``model.lattice.bond: beam``
on a solid): the calibration of 3D beams to nu 0.15 checked on a bar packed
with another seed; the model's stiffness at rest (hexahedra padded to six
DOFs, beams between core particles, beams carried to the band's nodes turning
with their cell's curl) gives a rigid motion no force; a pulse through the 3D
bar's random packing closes its energy audit with its particles turning;
a rigid spin about a skew axis starts every particle spinning and strains
nothing; and the bad inputs, each one line (breaking beams with contact,
restarted on 2 ranks: docs/bonds.md, measured by hand, three calibrations
being too long for the suite).

The calibration (about 15 s: conjugate gradients on 20^3 samples of 31k
DOFs) is made once per test process (cached) and shared by the tests of this
module, which run in-process."""
from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

from conftest import refused, run_scene, write_scene
from solver.model import calibration
from test_packing import uniaxial_bar
from test_transition import bar3d

NU = 0.15


def beam_bar3d():
    raw = bar3d()
    raw["model"]["material"]["nu"] = NU
    raw["model"]["lattice"].update(kind="random", geometry="nonlinear", bond="beam")
    raw["partitions"][0]["ratio"] = 1
    raw.pop("damping")
    return raw


@pytest.fixture(scope="module")
def model():
    from solver import scene as scene_mod
    from solver.model import arrays, binding
    raw = beam_bar3d()
    raw["output"] = {"file": "unused.h5"}
    return arrays.build(binding.bind(scene_mod.from_dict(raw)))


def test_3d_beams_calibrate_nu_and_other_packings_have_the_modulus(model):
    """The scene's calibration (seed 0, the bar's spread and gap) finds psi
    with nu 0.15 on one sample (to 2e-4), then E and nu as the mean of four
    samples at that psi (nu within 0.005 of the target; measured 0.1489);
    bars of 30 x 10 x 10 spacings packed with seeds 5-7, rotations free,
    tested by their end force, have a mean E within 5 % (measured 1.6 %;
    each 0.998-1.052) and nu within 0.03 (measured 0.160-0.164: free
    sides near)."""
    kappa, psi, m = calibration.calibrate_beams(1.0, NU, "solid", 0.0, 1.0, 0)
    one = calibration.measure(3, 0.0, 1.0, 0, psi)
    assert abs(one.nu - NU) < 2e-4 and 0.0 < psi < calibration.SHEAR_RANGE[1]
    assert m.samples == calibration.BEAM_SAMPLES and abs(m.nu - NU) < 5e-3
    bars = np.array([uniaxial_bar(3, 0.0, 1.0, seed, kappa, psi) for seed in (5, 6, 7)])
    assert abs(bars[:, 0].mean() - 1.0) < 0.05, bars
    assert np.abs(bars[:, 1] - NU).max() < 0.03, bars
    assert model.dof == 6 and model.rotary is not None


def test_a_rigid_motion_of_the_whole_3d_model_costs_nothing(model):
    """K q = 0 for an infinitesimal rigid rotation about a skew axis w (u = w x
    X, every node's rotation w) and for a translation, K the model's stiffness
    at rest; |K q| below 1e-12 of |K| |q|.  The same motion with the
    particles held unturned is not free: their torques are a million times
    that."""
    from scipy.sparse import coo_matrix
    rows, cols, vals = [], [], []
    for conn, Ke in model.stiffness_blocks(np.arange(model.n_nodes)):
        dofs = (conn[:, :, None] * 6 + np.arange(6)).reshape(len(conn), -1)
        blocks = Ke[np.arange(len(conn))]
        rows.append(np.repeat(dofs, dofs.shape[1], axis=1).ravel())
        cols.append(np.tile(dofs, (1, dofs.shape[1])).ravel())
        vals.append(blocks.ravel())
    n = model.n_dofs
    K = coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                   shape=(n, n)).tocsr()
    scale = abs(K).max()
    X = model.points - model.points.mean(axis=0)
    w = np.array([0.3, -0.5, 0.8])
    spin = np.hstack([np.cross(w, X), np.tile(w, (model.n_nodes, 1))])
    shift = np.zeros((model.n_nodes, 6))
    shift[:, :3] = [1.0, -2.0, 0.5]
    for q in (spin.ravel(), shift.ravel()):
        assert np.abs(K @ q).max() < 1e-12 * scale * np.abs(q).max()
    still = spin.copy()
    still[:, 3:] = 0.0
    torque = np.abs(K @ still.ravel()).reshape(-1, 6)[model.zone.n_mesh:, 3:]
    assert torque.max() > 1e6 * np.abs(K @ spin.ravel()).max()


def test_a_pulse_crosses_the_3d_beam_packing_with_its_audit_closed(model, tmp_path):
    """The half-sine push crosses the band into the beam-bonded core: the
    energy audit closes to 1e-3 of the work (measured 3.4e-4, as the
    central-bond packing's 3.2e-4 at this step), the particles turn (up to
    1e-6 rad), the probe in the core moves."""
    raw = beam_bar3d()
    raw["output"] = {"energy_every": 10, "fields": {"every": 240}}
    result = run_scene(raw, tmp_path)
    e = result.energy
    W = e["external_work"]
    audit = np.abs(e["kinetic"] + e["strain"] + e["dissipated"] - W).max() / W.max()
    assert audit < 1e-3, audit
    assert np.abs(result.probes["P"]["displacement"]).max() > 1e-8
    with h5py.File(tmp_path / "bar3d_transition_particles.h5") as f:
        turned = [f[k][()] for k in f if f[k].ndim == 2 and f[k].shape[1] == 3]
    assert max(np.abs(t).max() for t in turned) > 1e-9
    xdmf = (tmp_path / "bar3d_transition_particles.xdmf").read_text()
    assert 'Attribute Name="rotation"' in xdmf and 'Attribute Name="angular_velocity"' in xdmf


def spinning(model, w):
    """The bar free (no support, load or probe), every point moving at first
    with the rigid spin ``w`` [rad/s] about the bar's centre."""
    c = [float(x) for x in model.points.mean(axis=0)]
    raw = beam_bar3d()
    raw["model"].pop("fixed")
    for key in ("loads", "probes"):
        raw.pop(key)
    r = [f"(x - {c[0]!r})", f"(y - {c[1]!r})", f"(z - {c[2]!r})"]
    velocity = [f"{w[(a + 1) % 3]!r} * {r[(a + 2) % 3]} - {w[(a + 2) % 3]!r} * {r[(a + 1) % 3]}"
                for a in range(3)]
    raw["initial"] = {"motion": [{"velocity": velocity}]}
    return raw


def test_a_skew_spin_starts_every_particle_spinning_and_strains_nothing(model, tmp_path):
    """initial.motion with a rigid spin's velocity (w = (30, -50, 80) rad/s
    about the bar's centre): every particle starts turning at w (half the
    field's curl, 1e-6), the mesh's rotations stay held, and 500 steps later
    (4.7e-4 rad turned) the strain energy is below 1e-6 of the kinetic
    and the kinetic energy is kept to 1e-6."""
    from solver import scene as scene_mod
    from solver.model import arrays, binding
    w = [30.0, -50.0, 80.0]
    raw = spinning(model, w)
    raw["time"]["end"] = 5.0e-6
    mdl = arrays.build(binding.bind(scene_mod.from_dict(dict(raw, output={"file": "x.h5"}))))
    v0 = mdl.v0.reshape(-1, 6)
    assert np.abs(v0[mdl.zone.n_mesh:, 3:] - w).max() < 1e-6 * 80.0
    assert not v0[:mdl.zone.n_mesh, 3:].any()
    raw["output"] = {"energy_every": 10}
    e = run_scene(raw, tmp_path).energy
    assert e["strain"].max() < 1e-6 * e["kinetic"][0], e["strain"].max() / e["kinetic"][0]
    assert abs(e["kinetic"][-1] / e["kinetic"][0] - 1) < 1e-6


def test_a_fast_spin_restarts_to_the_same_state_with_its_orientations(model, tmp_path):
    """Spun at 3e4 rad/s about a skew axis (0.12 rad in 400 steps, the bar
    stretching under it), stopped at step 200 and restarted: the state at
    the end is the uninterrupted run's to 1e-12 (measured: identical), the
    particles' orientations coming from the checkpoint.  Restarted from the
    same checkpoint without them (orientations exp(theta), as a checkpoint
    written before they were kept), the state differs by more than 1e-6:
    the rotation DOFs of particles whose spin axis moves are not their
    rotation vectors."""
    from mpi4py import MPI

    from solver.driver.runner import run
    from solver.model import binding
    raw = spinning(model, [9e3, -1.5e4, 2.4e4])
    dt = raw["time"]["dt"]

    def go(name, steps, restart=None):
        scene = dict(raw, name="spin", time=dict(raw["time"], end=steps * dt),
                     output={"file": str(tmp_path / f"{name}.h5"), "progress": 0,
                             "checkpoint": {"every": 100}})
        run(binding.from_dict(scene), MPI.COMM_SELF, log=lambda *a: None, restart=restart)
        with h5py.File(tmp_path / f"{name}.h5") as f:
            return {n: f[f"checkpoint/partitions/{n}/uva"][()] for n in ("dem", "fem")}
    whole = go("whole", 400)
    go("short", 200)
    shutil.copy(tmp_path / "short.h5", tmp_path / "bare.h5")
    with h5py.File(tmp_path / "bare.h5", "a") as f:
        del f["checkpoint/partitions/dem/orientations"]
    bare = go("bare", 400, restart=str(tmp_path / "bare.h5"))
    short = go("short", 400, restart=str(tmp_path / "short.h5"))
    for name, want in whole.items():
        scale = np.abs(want).max(axis=(1, 2))
        assert (np.abs(short[name] - want).max(axis=(1, 2)) <= 1e-12 * scale).all(), name
    dem = np.abs(bare["dem"] - whole["dem"]).max(axis=(1, 2)) / np.abs(whole["dem"]).max(axis=(1, 2))
    assert dem.min() > 1e-6, dem


@pytest.mark.parametrize("sets,words", [
    (["model.lattice.contact.stiffness=1e6", "model.lattice.contact.friction=0.3",
      "model.lattice.contact.friction_model=viscous",
      "model.lattice.contact.rolling_friction=0.1"], "model.lattice.contact.rolling_friction"),
    (["model.material.nu=0.3"], "central bonds' 0.24"),
])
def test_bad_3d_beam_scenes_are_refused_in_one_line(tmp_path, sets, words):
    """Rolling resistance without shear springs (friction_model viscous), or
    a nu above the central bonds' (which 3D beams only lower): one line,
    exit 2, no output."""
    scene = write_scene(tmp_path / "beam3d.yaml", beam_bar3d())
    line = refused(scene, sets, tmp_path)
    assert words in line, line
