"""The declared model interface (solver/model/interface.py): both model kinds
satisfy it, the optional features are present exactly where the scene asks for
them, and nothing in solver/ probes a model with getattr/hasattr any more."""
from __future__ import annotations

import ast
import copy
from pathlib import Path

import numpy as np
import pytest

from conftest import raw_scene

ROOT = Path(__file__).resolve().parents[1]


def model(raw, tmp_path):
    """The bound scene and the whole model of raw scene data."""
    from solver import scene as scene_mod
    from solver.model import arrays, binding
    raw = dict(copy.deepcopy(raw), output={"file": str(tmp_path / "m.h5")})
    bound = binding.bind(scene_mod.from_dict(raw))
    return bound, arrays.build(bound)


def network():
    return raw_scene("six_dof")


def continuum():
    return raw_scene("wave_bar_fem")


def shell():
    raw = raw_scene("plate_shell")
    raw["model"]["mesh_parameters"] = {"n": 4}
    return raw


def shells_and_solid():
    raw = raw_scene("block_strip")
    raw["model"]["mesh_parameters"] = {"n": 2, "nl": 4}
    return raw


def lattice_contact():
    raw = raw_scene("wave_bar_transition")
    raw["model"]["lattice"]["geometry"] = "nonlinear"
    raw["model"]["lattice"]["break_strain"] = 3e-4
    raw["model"]["lattice"]["contact"] = {"stiffness": 1.68e7}
    return raw


def lattice():
    return raw_scene("wave_bar")


def heat():
    raw = raw_scene("laser_disc")
    raw["model"]["mesh_parameters"] = {"h": 0.008}
    return raw


def transition():
    return raw_scene("wave_bar_transition")


# scene -> (kind, features present)
CASES = {
    "network": (network, "network", ()),
    "continuum": (continuum, "continuum", ()),
    "shell": (shell, "continuum", ("shells",)),
    "shells_and_solid": (shells_and_solid, "continuum", ("shells",)),
    "lattice": (lattice, "continuum", ("lattice",)),
    "lattice_contact": (lattice_contact, "continuum", ("lattice", "contact", "zone")),
    "heat": (heat, "continuum", ("heat",)),
    "transition": (transition, "continuum", ("lattice", "zone")),
}


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("models")
    return {name: model(make(), tmp) for name, (make, _, _) in CASES.items()}


@pytest.mark.parametrize("name", CASES)
def test_every_model_satisfies_the_interface(models, name):
    from solver.model.interface import FEATURES, ModelInterface, features
    _, mdl = models[name]
    _, kind, present = CASES[name]
    assert isinstance(mdl, ModelInterface)
    assert mdl.kind == kind
    assert features(mdl) == tuple(f for f in FEATURES if f in present)
    assert (mdl.points is None) == (kind == "network")
    if mdl.points is not None:
        assert mdl.points.shape[0] == mdl.n_nodes
    assert mdl.mass.shape == (mdl.n_nodes,)
    assert mdl.fixed.shape == mdl.u0.shape == mdl.v0.shape == (mdl.n_dofs,)
    assert mdl.dofmap.n_dofs == mdl.n_dofs
    # a share keeps the declared interface and the features
    share = mdl.share(np.arange(min(3, mdl.n_nodes)))
    assert isinstance(share, ModelInterface) and features(share) == features(mdl)


def test_a_network_declares_every_feature_absent():
    from solver.model.arrays import Model
    from solver.model.interface import FEATURES
    fields = {f.name for f in __import__("dataclasses").fields(Model)}
    assert not fields & set(FEATURES)              # class attributes, not constructor arguments
    assert all(getattr(Model, f) is None for f in FEATURES)
    assert Model.points is None and Model.notes == () and Model.kind == "network"


def test_feature_contents(models):
    """What each feature carries, in numbers."""
    _, mdl = models["shell"]
    assert mdl.dof == 6 and mdl.shells.inertia.shape == (mdl.n_nodes,)
    assert np.all(mdl.shells.inertia > 0)
    _, mixed = models["shells_and_solid"]
    assert mixed.dof == 6 and mixed.shells.inertia.shape == (mixed.n_nodes,)
    # solid-only nodes have their rotations fixed
    still = mixed.fixed.reshape(-1, 6)[:, 3:].all(axis=1)
    assert still.any() and not still.all()

    bound, lat = models["lattice"]
    assert lat.lattice.geometry == "linear" and lat.lattice.break_strain is None
    bi, bj, k = lat.lattice.bonds
    assert bi.size == bj.size == k.size > 0 and np.all(k > 0)
    assert lat.lattice.carried == ()
    assert lat.contact is None

    _, con = models["lattice_contact"]
    assert con.lattice.geometry == "nonlinear" and con.lattice.break_strain == 3e-4
    c = con.contact
    radius, skin = c.radius, c.skin
    assert (c.law.stiffness, c.law.name) == (1.68e7, "linear")
    assert radius == pytest.approx(0.5 * bound.model.lattice.spacing)
    assert skin == pytest.approx(0.3 * radius)

    _, tr = models["transition"]
    assert tr.zone.n_mesh + tr.zone.n_core == tr.n_nodes
    assert tr.lattice.bonds is tr.zone.bonds and tr.lattice.carried is tr.zone.blocks
    assert tr.lattice.overlap_cells == ()

    _, ht = models["heat"]
    assert ht.heat.n_model == ht.n_nodes
    assert ht.heat.spec.conductivity == 233.0


def test_a_share_keeps_only_the_bonds_it_touches(models):
    _, lat = models["lattice"]
    bi, bj, _ = lat.lattice.bonds
    nodes = np.unique(bi[:5])
    share = lat.share(nodes)
    si, sj, sk = share.lattice.bonds
    touch = np.isin(bi, nodes) | np.isin(bj, nodes)
    assert si.size == int(touch.sum()) < bi.size
    assert np.array_equal(si, bi[touch]) and np.array_equal(sj, bj[touch])
    assert share.lattice.geometry == lat.lattice.geometry


def test_a_dem_rank_share_has_no_body_cells_and_zero_states_travel_as_zeros(models):
    """A rank that steps no fem partition gets no body cells (without a band),
    the same bond and overlap blocks; with a band it keeps them (its dem
    piece steps cells). An all-zero u0 / v0 pickles as np.zeros (a few bytes,
    received as a plain writable array); a non-zero one travels as it is."""
    import dataclasses
    import pickle
    from solver.model.continuum import BondStiffness
    _, lat = models["lattice"]
    nodes = np.unique(lat.lattice.bonds[0][:50])
    dem = lat.share(nodes, body_cells=False)
    full = lat.share(nodes)
    assert sum(len(c) for _, c, _ in full.cells) > 0
    assert sum(len(c) for _, c, _ in dem.cells) == 0
    for (c1, k1), (c2, k2) in zip(dem.bond_blocks(nodes), full.bond_blocks(nodes)):
        assert np.array_equal(c1, c2)
        if isinstance(k1, BondStiffness):
            assert np.array_equal(k1.k, k2.k)
        else:
            assert np.array_equal(k1[np.arange(len(c1))], k2[np.arange(len(c2))])
    _, band = models["transition"]
    kept = band.share(np.arange(band.n_nodes), body_cells=False)
    assert sum(len(c) for _, c, _ in kept.cells) == sum(len(c) for _, c, _ in band.cells) > 0
    assert not lat.u0.any()
    small = pickle.dumps(dem.u0, protocol=5, buffer_callback=lambda b: None)
    assert len(small) < 200
    back = pickle.loads(pickle.dumps(dem, protocol=5))
    assert type(back.u0) is np.ndarray and back.u0.flags.writeable
    assert np.array_equal(back.u0, lat.u0) and np.array_equal(back.v0, lat.v0)
    moving = dataclasses.replace(lat, v0=np.linspace(0.0, 1.0, lat.n_dofs))
    sent = pickle.loads(pickle.dumps(moving.share(nodes), protocol=5))
    assert np.array_equal(sent.v0, moving.v0)


def test_a_side_model_answers_through_the_declared_names(models):
    from solver.coupling.conserving import SideModel
    from solver.model.interface import ModelInterface, features
    for name in ("network", "transition"):
        _, mdl = models[name]
        side = SideModel(mdl, lambda conn: np.ones(len(conn), bool), mdl.loads)
        assert isinstance(side, ModelInterface)
        assert features(side) == features(mdl) and side.kind == mdl.kind


def test_the_continuum_model_is_built_with_keywords():
    """No ContinuumArrays(...) call in solver/ passes a positional argument."""
    calls = []
    for path in sorted((ROOT / "solver").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", getattr(
                    node.func, "attr", None)) == "ContinuumArrays":
                calls.append((path.name, node.lineno, len(node.args)))
    assert len(calls) == 4, calls          # continuum (plain, transition), shell_model (2)
    assert all(n == 0 for _, _, n in calls), calls


# every attribute a model has, and the names it had before the interface
MODEL_NAMES = {"model", "mdl", "arrays", "share", "side"}
MODEL_ATTRS = {"kind", "dof", "mass", "fixed", "loads", "u0", "v0", "points", "notes", "cells",
               "shells", "lattice", "contact", "heat", "zone", "dofmap", "n_nodes", "n_dofs",
               "material_D", "inertia", "bonds", "overlap_cells", "carried", "bond_geometry",
               "break_strain", "gravity"}
# (file, object, attribute) of the getattr/hasattr calls that may stay: none asks a model
ALLOWED = {
    ("model/interface.py", "model", None),          # features(): every FEATURES name
    ("coupling/conserving.py", "self._model", None),  # SideModel delegates to its model
    ("coupling/conserving.py", "scene.model", "lattice"),   # the scene's model section
    ("model/data.py", "data", "points"),              # model data: a Mesh or a Network
    ("driver/runner.py", "scene.reference", "kind"),  # the scene's reference: a name or a section
    ("driver/comparison.py", "scene.reference", "kind"),
}


def probes():
    """(file, object, attribute or None) of every getattr/hasattr on a model
    name or a model attribute in solver/."""
    out = set()
    for path in sorted((ROOT / "solver").rglob("*.py")):
        rel = path.relative_to(ROOT / "solver").as_posix()
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("getattr", "hasattr") and len(node.args) >= 2):
                continue
            obj, attr = node.args[0], node.args[1]
            name = attr.value if isinstance(attr, ast.Constant) else None
            base = obj.id if isinstance(obj, ast.Name) else None
            if base in MODEL_NAMES or name in MODEL_ATTRS or \
                    (isinstance(obj, ast.Attribute) and obj.attr in ("model", "_model")):
                out.add((rel, ast.unparse(obj), name))
    return out


def test_no_getattr_or_hasattr_asks_a_model():
    assert probes() == ALLOWED
