"""Continuum FEM from gmsh meshes: the wave_bar against the 1D analytic wave,
coupled continuum partitions, 1 vs 2 ranks, and scene errors."""
import numpy as np
import pytest

from conftest import raw_scene, run_cli, run_scene, write_scene

E, RHO, THICK, Q, T = 70e9, 2700.0, 3.2e-4, 1.0e4, 1.5e-5
C = np.sqrt(E / RHO)
V0 = (Q / THICK) / (RHO * C)          # particle velocity of the 1D wave


def half_rise(t, v):
    peak = v.max()
    k = int(np.argmax(v >= 0.5 * peak))
    return t[k - 1] + (0.5 * peak - v[k - 1]) / (v[k] - v[k - 1]) * (t[k] - t[k - 1]), peak


def test_wave_bar_fem_matches_the_1d_wave(tmp_path):
    res = run_scene(raw_scene("wave_bar_fem"), tmp_path)
    assert res.partitions["fem"]["steps"] == 2750
    for name, x in (("A", 0.078), ("B", 0.160), ("C", 0.242)):
        pr = res.probes[name]
        arrival, peak = half_rise(pr["t"], pr["velocity"])
        arrival -= T / 6                   # a half-sine reaches half its peak at T/6
        assert abs(arrival / (x / C) - 1) < 0.01, (name, arrival, x / C)
        assert abs(peak / V0 - 1) < 0.05, (name, peak, V0)


def split_bar(tmp_path, eta=2, end=1.2e-5):
    raw = raw_scene("wave_bar_fem")
    raw["name"] = "bar_split"
    raw["time"] = {"end": end, "dt": 1e-8}
    raw["model"]["mesh"] = "meshes/bar_split.geo"
    raw["partitions"] = [
        {"name": "west", "method": "fem", "group": "west", "integrator": "explicit", "ratio": eta},
        {"name": "east", "method": "fem", "group": "east", "integrator": "explicit", "ratio": 1}]
    raw["probes"] = [{"name": "mid", "at": [0.024, 0.0012]}, {"name": "w", "at": [0.008, 0.0008]}]
    return raw


def test_coupled_continuum_partitions_match_a_single_one(tmp_path):
    coupled = run_scene(split_bar(tmp_path), tmp_path)
    raw = split_bar(tmp_path)
    raw["partitions"] = [{"name": "all", "method": "fem", "group": "solid",
                          "integrator": "explicit", "ratio": 1}]
    raw["name"] = "bar_single"
    single = run_scene(raw, tmp_path)
    assert coupled.partitions["west"]["n_external"] > 0 and coupled.partitions["west"]["steps"] == 600
    for probe in ("mid", "w"):
        a = coupled.probes[probe]["velocity"]
        b = single.probes[probe]["velocity"][::2]
        assert np.abs(b).max() > 0.5 * V0
        assert np.abs(a - b).max() < 0.02 * np.abs(b).max(), probe


def test_continuum_errors(tmp_path):
    cases = [
        (("model", "fixed"), ["nope"], "model.fixed: mesh has no physical group 'nope'; it has: left"),
        (("model", "material"), {"E": 70e9, "nu": 0.33, "rho": 2700.0, "kind": "solid"},
         "model.material.kind: solid does not fit a 2D mesh"),
        (("reference",), "modal", "reference: modal references are for network models"),
        (("model", "mesh"), "meshes/nope.geo", "model.mesh: meshes/nope.geo: mesh file not found"),
    ]
    for path, value, message in cases:
        raw = raw_scene("wave_bar_fem")
        node = raw
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
        proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
        assert proc.returncode == 2, (path, proc.stderr)
        assert message in proc.stderr, proc.stderr
