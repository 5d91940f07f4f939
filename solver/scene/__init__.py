"""Stage 1, the scene: YAML parsed into typed, validated, frozen configuration.

``sections`` declares every key (the Scene and its sections), ``model_spec``
the model section, ``schema`` the typed parser, ``file`` reading a scene file
and ``--set`` overrides.  Nothing here reads a mesh or builds arrays; the model
stage binds the scene to its model data (:mod:`solver.model.binding`: ``load``,
``from_dict``), called by the entry points.
"""
from solver.scene.file import apply_override, from_dict, load, load_raw, yaml_load
from solver.scene.sections import (BarWaveReference, Checkpoint, Coupling, Damping, Fields,
                                   Guard, Initial, Load, MonolithicReference, Output, Partition,
                                   Probe, Scene, Time)

__all__ = ["apply_override", "from_dict", "load", "load_raw", "yaml_load", "BarWaveReference",
           "Checkpoint", "Coupling", "Damping", "Fields", "Guard", "Initial", "Load",
           "MonolithicReference", "Output", "Partition", "Probe", "Scene", "Time"]
