"""Ground truth as a lab's recorder leaves it, never on the fitted model's tick grid.

The TRUTH table (identify_truth) runs at FINE_RATE (4 kHz: its drive cycle, sensors and
controller tick four times per tick of the 1 kHz model fitted to it), with the same
1 ms measurement delay (four of its ticks); the commands are logged at their own 0.25 ms
times. :func:`retime` then makes a ``ros2 bag record`` of a slower, jittered driver out
of it: joint_states at ``rate`` Hz, each sample the fine sample nearest a jittered time
(up to a third of a period either way) stamped with its true time plus a constant
offset from the log times, losses in bursts, repeated messages, the lab's joint names.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from identify_truth import EXCITATION, SHORT, TRUTH

from screwgear_ros.inprocess.scenario import load_scenario
from screwgear_ros.inprocess.simulation import Simulation, file_values

FINE_RATE = 4000.0
PRESET_FILE = Path(__file__).resolve().parents[2] / 'config' / 'realistic.yaml'
#: What a lab calls the joints.
LAB_NAMES = {'pinion_1': 'motor_a', 'table': 'axis_c', 'pinion_3': 'motor_b'}


def fine_simulation(**changes: Any) -> Simulation:
    """The TRUTH table at FINE_RATE, its sensors' delay kept at 1 ms."""
    per = int(FINE_RATE / 1000)
    delays = {f'measurement_delay_{j}': per for j in ('table', 'pinion_1', 'pinion_3')}
    scenario = load_scenario(EXCITATION)
    return Simulation.from_values({**dict(scenario.values), **file_values(PRESET_FILE)},
                                  **{**TRUTH, 'publish_rate': FINE_RATE, **delays, **changes})


def chirp(duration: float) -> Callable[[Any], float]:
    """The shipped excitation, shortened (identify_truth.SHORT)."""
    from screwgear_ros.identification.excitation import make
    spec = load_scenario(EXCITATION).controller
    assert spec is not None
    return make(**{**dict(spec.parameters), **SHORT})


def pd_steps(duration: float, seed: int = 3, gain: float = 4000.0, damping: float = 150.0,
             step: float = 0.004, hold: float = 0.6, dither: float = 0.6
             ) -> Callable[[Any], float]:
    """A closed-loop PD on the table's measured angle following steps of ±``step`` rad
    every ``hold`` s, plus a seeded pseudo-random dither of ±``dither`` N·m held 5 ms."""
    rng = np.random.default_rng(seed)
    targets = step * rng.choice([-1.0, 1.0, 0.5, -0.5], size=int(duration / hold) + 2)
    bits = dither * np.where(rng.random(int(duration / 0.005) + 2) < 0.5, -1.0, 1.0)

    def controller(observation: Any) -> float:
        t = float(observation.time)
        target = targets[int(t / hold)]
        error = target - observation.position[1]
        u = gain * error - damping * observation.velocity[1] + bits[int(t / 0.005)]
        return float(np.clip(u, -20.0, 20.0))

    return controller


def record_fine(path: Path, controller: Callable[[Any], float], duration: float,
                phase: int = 1, **changes: Any) -> Path:
    """Record ``controller`` on :func:`fine_simulation` for ``duration`` s to ``path``:
    it answers at 1 kHz as a lab's drive is commanded, at the fine tick ``phase`` of
    each millisecond (so the commands' times are off the 1 kHz grid), None between."""
    per = int(FINE_RATE / 1000)
    simulation = fine_simulation(**changes)
    steps = simulation.settings.steps_per_publish

    def held(observation: Any) -> float | None:
        return controller(observation) if (observation.step // steps) % per == phase \
            else None

    simulation.run(held, duration, path)
    return path


def retime(src: Path, dst: Path, rate: float = 800.0, seed: int = 7, jitter: float = 1 / 3,
           loss: float = 0.06, burst: int = 8, repeats: float = 0.01,
           offset_ns: int = 2_500_000, names: dict[str, str] | None = None,
           storage: str = 'sqlite3') -> Path:
    """A plain bag (joint_states, cmd_effort) of ``src`` as a lab's recorder leaves it.

    ``loss``: the share of joint_states lost, half singly and half in bursts of
    ``burst``; ``repeats``: the share logged twice (same header stamp, a later log time);
    ``offset_ns``: header stamps minus log times.
    """
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer

    from screwgear_ros.bag.format import typestore
    store = typestore()
    rng = np.random.default_rng(seed)
    names = LAB_NAMES if names is None else names
    fine_period = round(1e9 / FINE_RATE)
    with AnyReader([src], default_typestore=store) as reader:
        states = [c for c in reader.connections if c.topic.rsplit('/', 1)[-1] == 'joint_states'
                  and 'true' not in c.topic]
        commands = [c for c in reader.connections if c.topic.endswith('cmd_effort')]
        joint = {int(t): (c, raw) for c, t, raw in reader.messages(connections=states)}
        effort = [(int(t), c, raw) for c, t, raw in reader.messages(connections=commands)]
        first = min(joint)
        last = max(joint)
        period = 1e9 / rate
        count = int((last - first) / period)
        nominal = first + np.arange(count) * period
        wanted = nominal + rng.uniform(-jitter, jitter, count) * period
        fine = np.clip(np.rint((wanted - first) / fine_period), 0, (last - first) // fine_period)
        picked = (first + fine * fine_period).astype(np.int64)
        keep = rng.random(count) >= loss / 2
        for start in rng.choice(count - burst, size=int(loss / 2 * count / burst), replace=False):
            keep[start:start + burst] = False
        keep[:3] = True
        with Writer(dst, version=9, storage_plugin=StoragePlugin.SQLITE3 if storage ==
                    'sqlite3' else StoragePlugin.MCAP) as writer:
            c0 = states[0]
            out_states = writer.add_connection('/joint_states', c0.msgtype, typestore=store)
            out_cmd = writer.add_connection('/cmd_effort', commands[0].msgtype, typestore=store)
            for t, _c, raw in effort:
                writer.write(out_cmd, t, raw)
            for k in np.flatnonzero(keep):
                t = int(picked[k])
                c, raw = joint[t]
                message = reader.deserialize(raw, c.msgtype)
                message.name = [names.get(n, n) for n in message.name]
                stamp = t + offset_ns
                message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 10 ** 9)
                data = store.serialize_cdr(message, c.msgtype)
                writer.write(out_states, t, data)
                if rng.random() < repeats:
                    writer.write(out_states, t + fine_period // 3, data)
    return dst


__all__ = ['FINE_RATE', 'LAB_NAMES', 'chirp', 'fine_simulation', 'pd_steps', 'record_fine',
           'retime']
