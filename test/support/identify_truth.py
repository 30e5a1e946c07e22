"""Ground truth for the identification tests: the realistic preset with changed values
(TRUTH), driven by the shipped excitation (shortened) with the preset's encoder noise,
recorded in-process as table_sim records it, and the same run as a plain bag (only
joint_states and cmd_effort, sqlite3 storage, no run_parameters) as ``ros2 bag record``
of a real table would hold it."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import yaml
from paths import ROOT as REPO

from screwgear_ros.inprocess.scenario import load_scenario
from screwgear_ros.inprocess.simulation import Simulation, file_values

PRESET = REPO / 'config' / 'realistic.yaml'
EXCITATION = REPO / 'docs' / 'examples' / 'identification_excitation.yaml'

#: The table the recordings come from: the preset with these values changed.
TRUTH = {'mesh_stiffness_mean': 1.15e7, 'mesh_damping': 800.0, 'table_coulomb_torque': 3.4,
         'pinion_coulomb_torque': 0.055, 'inertia_table': 48.0, 'backlash': 8.0e-5,
         'preload_torque': 330.0, 'drive_time_constant': 1.8e-4}
#: The shipped excitation, one cycle shortened to 3 s (the suite's time budget).
SHORT = {'phase': 1.0, 'slow_phase': 0.5}
DURATION = 3.0


def truth_simulation(**changes: Any) -> Simulation:
    scenario = load_scenario(EXCITATION)
    return Simulation.from_values({**dict(scenario.values), **file_values(PRESET)},
                                  **{**TRUTH, **changes})


def record_excitation(path: Path, duration: float = DURATION, **controller: Any) -> Path:
    """The shipped excitation scenario (its controller's parameters changed by
    ``controller``), on the TRUTH table, recorded to ``path``."""
    scenario = load_scenario(EXCITATION)
    spec = scenario.controller
    assert spec is not None
    parameters = {**dict(spec.parameters), **SHORT, **controller}
    scenario = dataclasses.replace(scenario, duration=duration, controller=dataclasses.replace(
        spec, parameters=tuple(parameters.items())))
    scenario.run(record=path, simulation=truth_simulation())
    return path


def copy_topics(src: Path, dst: Path, keep: Iterable[str], storage: str = 'sqlite3',
                change: Callable[[str, Any], Any] | None = None) -> Path:
    """A new bag ``dst`` with only the topics whose relative name is in ``keep``, written
    with rosbags' writer (``storage`` 'sqlite3' or 'mcap'); ``change(topic, message)``
    may edit a message before it is written, or drop it (None)."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer

    from screwgear_ros.bag.format import typestore
    store = typestore()
    plugin = StoragePlugin.SQLITE3 if storage == 'sqlite3' else StoragePlugin.MCAP
    keep = set(keep)
    with AnyReader([src], default_typestore=store) as reader, \
            Writer(dst, version=9, storage_plugin=plugin) as writer:
        out = {}
        chosen = [c for c in reader.connections if c.topic.rsplit('/', 1)[-1] in keep]
        for c in chosen:
            out[c.id] = writer.add_connection(c.topic, c.msgtype, typestore=store)
        for c, stamp, raw in reader.messages(connections=chosen):
            if change is not None:
                message = change(c.topic.rsplit('/', 1)[-1], reader.deserialize(raw, c.msgtype))
                if message is None:       # dropped
                    continue
                raw = store.serialize_cdr(message, c.msgtype)
            writer.write(out[c.id], stamp, raw)
    return dst


def write_base(path: Path, fit: Sequence[str], extra: dict[str, Any] | None = None) -> Path:
    """The preset with every TRUTH value not fitted (the fitted ones stay the preset's,
    the paper's where it sets none), as a parameter file."""
    lines = PRESET.read_text(encoding='utf-8').rstrip('\n').splitlines()
    values = {**{k: v for k, v in TRUTH.items() if k not in fit}, 'command_timeout': 0.0,
              **(extra or {})}
    # a parameter file names each parameter once: the preset's line gives way to ours
    lines = [line for line in lines if line.strip().split(':')[0] not in values]
    lines += [f'    {name}: {yaml.safe_dump(value).splitlines()[0]}'
              for name, value in values.items()]
    path.write_text('\n'.join(lines) + '\n', encoding='utf-8')
    return path


__all__ = ['DURATION', 'EXCITATION', 'PRESET', 'SHORT', 'TRUTH', 'copy_topics',
           'record_excitation', 'truth_simulation', 'write_base']
