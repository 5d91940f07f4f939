"""Probes that record shell stress: at a node of shell cells a probe's
``stress`` is the von Mises stress of the larger face, N / t -+ 6 M / t^2,
averaged over the node's shell cells (the fields' von_mises, at a node).
Exact on states the elements represent exactly: a plate bent by an end
rotation (sigma = E t kappa / 2) and stretched by an end displacement
(sigma = E delta / L), triangles and quadrilaterals, 1 and 2 ranks; on shells
joined to a solid, probes at solid nodes keep sigma_cc."""
import h5py
import numpy as np
import pytest

from conftest import ROOT, run_cli, write_scene

E, T = 210.0e9, 0.01


def plate(tmp_path, name, dofs, value, quads=0, membrane="allman", constraints=(), n=None):
    """The unit shell plate (nu = 0), edge x = 0 clamped, edge x = 1 driven
    statically: value at time.end on ``dofs``."""
    raw = {
        "name": name, "analysis": "static", "time": {"end": 1.0, "dt": 1.0},
        "model": {"kind": "continuum", "mesh": str(ROOT / "meshes" / "plate_shell.geo"),
                  "mesh_parameters": {"n": 4, "quads": quads},
                  "material": {"E": E, "nu": 0.0, "rho": 7800.0, "kind": "shell",
                               "thickness": T, "membrane": membrane},
                  "body": "plate", "fixed": ["x0"], "constraints": list(constraints),
                  "prescribed": [{"group": "x1", "dofs": dofs, "quantity": "displacement",
                                  "kind": "tabulated", "table": [[0.0, 0.0], [1.0, value]]}]},
        "probes": [{"name": "centre", "at": [0.5, 0.5, 0.0], "component": 2},
                   {"name": "edge", "at": [0.5, 0.0, 0.0], "component": 2}],
        "output": {"file": str(tmp_path / f"{name}.h5"), "progress": 0},
    }
    proc = run_cli([write_scene(tmp_path / f"{name}.yaml", raw)], n=n)
    assert proc.returncode == 0, proc.stderr
    with h5py.File(tmp_path / f"{name}.h5") as f:
        attrs = f["probes/centre"].attrs["stress"]
        return {k: float(f[f"probes/{k}/stress"][0]) for k in ("centre", "edge")}, attrs


@pytest.mark.parametrize("quads, n", [(0, None), (1, None), (0, 2)])
def test_a_plate_bent_by_an_end_rotation_probes_e_t_kappa_over_2(tmp_path, quads, n):
    theta = 0.01                                       # kappa = theta / L, L = 1 m
    got, attrs = plate(tmp_path, "bent", ["ry"], theta, quads=quads, n=n)
    assert attrs.startswith("von Mises [Pa] of the larger face")
    for where, sigma in got.items():
        assert sigma == pytest.approx(E * T * theta / 2, rel=1e-9), where


@pytest.mark.parametrize("membrane, quads", [("allman", 0), ("andes", 0), ("cst", 0),
                                             ("allman", 1)])
def test_a_plate_stretched_by_an_end_displacement_probes_e_delta_over_l(tmp_path, membrane,
                                                                         quads):
    """The driven edge holds its drilling rotation too: with the allman and
    andes membranes the in-plane displacement between two nodes depends on
    them, so an edge driven at its nodes alone bulges (guide/prescribed.md)."""
    delta = 1e-4
    got, _ = plate(tmp_path, "stretched", ["ux"], delta, quads=quads, membrane=membrane,
                   constraints=[{"group": "x1", "dofs": ["rz"]}])
    for where, sigma in got.items():
        assert sigma == pytest.approx(E * delta, rel=1e-9), where


def test_shells_on_a_solid_probe_von_mises_and_sigma_xx(tmp_path):
    """The strip welded to a block (tests/test_shell.py) pulled at its tip: a
    probe on the strip records von Mises, one in the block sigma_xx, a
    rotation component there NaN; 1 and 2 ranks agree."""
    from test_shell import block_strip
    raw = block_strip()
    raw["name"] = "welded"
    raw["time"] = {"end": 1e-4, "dt": 1e-7}
    raw["loads"] = [{"at": [1.0, 0.05, 0.0], "component": 0, "kind": "tabulated",
                     "table": [[0.0, 0.0], [5e-5, 1e3], [1.0, 1e3]]}]
    raw["probes"] = [{"name": "strip", "at": [0.25, 0.05, 0.0], "component": 0},
                     {"name": "block", "at": [-0.05, 0.05, 0.025], "component": 0},
                     {"name": "block_rx", "at": [-0.05, 0.05, 0.025], "component": 3}]
    out = {}
    for n in (None, 2):
        raw["output"] = {"file": str(tmp_path / f"welded{n}.h5"), "progress": 0}
        proc = run_cli([write_scene(tmp_path / "welded.yaml", raw)], n=n)
        assert proc.returncode == 0, proc.stderr
        with h5py.File(tmp_path / f"welded{n}.h5") as f:
            out[n] = {k: f[f"probes/{k}/stress"][()] for k in ("strip", "block")}
            assert f["probes/strip"].attrs["stress"].startswith("von Mises")
            assert f["probes/block"].attrs["stress"].startswith("sigma_xx [Pa]")
            # a rotation component at a solid node (held): no stress component
            assert np.isnan(f["probes/block_rx/stress"][()]).all()
            assert f["probes/block_rx"].attrs["stress"].startswith("none (NaN)")
    assert out[None]["strip"].max() > 1e3 and out[None]["strip"].min() >= 0.0
    assert abs(out[None]["block"]).max() > 10.0          # (the wave has just reached it)
    for k in ("strip", "block"):
        a, b = out[None][k], out[2][k]
        assert abs(a - b).max() <= 1e-10 * abs(a).max(), k
