"""What the figures of a recorded run draw, as data: event marks, the drive input, the
parameters in force, the contact state, the setpoint and the tracking error.

No ROS and no matplotlib here. The input in force at each step is the node's own fold of
the recorded commands, taken from the ticks of an in-process replay
(:func:`screwgear_ros.runs.replay_in_process.replay_in_process`), so the drawn torque is
the one the node integrated (validated, cut by a lowered limit, kept through a reset).
"""


from dataclasses import dataclass

import numpy as np

from ..bag.reader import RecordedRun
from ..params.table import TableParams
from ..sim.events import ParameterChange, Reset
from ..sim.plant import DriveInput
from ..sim.session import Tick


@dataclass(frozen=True)
class ParameterMark:
    """A recorded parameter change: when it took effect and which values it changed."""

    time: float                 # s
    changed: tuple[str, ...]    # ROS parameter names whose value differs from before


@dataclass(frozen=True)
class RunMarks:
    """The events drawn across every panel, and the commanded reversals."""

    parameter_changes: tuple[ParameterMark, ...]
    resets: tuple[float, ...]                   # s
    reversals: tuple[tuple[float, int], ...]    # (s, commanded direction after it)


def _values(change: ParameterChange) -> dict[str, object]:
    return {**change.params.as_dict(), **change.settings.as_dict()}


def run_marks(run: RecordedRun, ticks: list[Tick] | None = None) -> RunMarks:
    """Parameter changes and resets as recorded; reversals from the replayed ``ticks``."""
    before = _values(ParameterChange(run.parameters.params, run.parameters.settings))
    changes: list[ParameterMark] = []
    resets: list[float] = []
    for _, event in run.events:
        assert event.step is not None      # a recorded event carries its step
        if isinstance(event, ParameterChange):
            now = _values(event)
            changes.append(ParameterMark(event.step * run.dt,
                                         tuple(k for k in now if now[k] != before.get(k))))
            before = now
        elif isinstance(event, Reset):
            resets.append(event.step * run.dt)
    reversals = tuple((t.start * run.dt, t.drive.direction) for t in ticks or () if t.reversal)
    return RunMarks(tuple(changes), tuple(resets), reversals)


def drive_series(run: RecordedRun, ticks: list[Tick]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times s, signed drive torque N·m, load torque N·m): the input in force from each
    time on (a step function), as the node folded the recorded commands; the last
    point is the end of the run."""
    drive = DriveInput()
    steps, torque, load = [run.parameters.start_step], [drive.torque * drive.direction], [drive.load]
    for tick in ticks:
        signed = tick.drive.torque * tick.drive.direction
        if (signed, tick.drive.load) != (torque[-1], load[-1]):
            steps.append(tick.start)
            torque.append(signed)
            load.append(tick.drive.load)
    steps.append(max(run.end_step, steps[-1]))
    torque.append(torque[-1])
    load.append(load[-1])
    return np.asarray(steps) * run.dt, np.asarray(torque), np.asarray(load)


def params_at(run: RecordedRun, ticks: list[Tick], steps: np.ndarray) -> list[TableParams]:
    """The parameters in force for the output sampled at each of ``steps``."""
    starts, params = [run.parameters.start_step], [run.parameters.params]
    for tick in ticks:
        if tick.params is not params[-1]:
            starts.append(tick.start)
            params.append(tick.params)
    # A sample at step s was computed with what took effect strictly before s.
    index = np.clip(np.searchsorted(starts, steps, side='left') - 1, 0, None)
    return [params[i] for i in index]


def in_contact(run: RecordedRun, ticks: list[Tick]) -> np.ndarray:
    """(n, 2) bool per mesh_state sample: mesh 1, mesh 3 on a flank (|δ| > b, or b = 0)."""
    sample_params = params_at(run, ticks, run.mesh_state.steps)
    backlash = np.array([p.backlash for p in sample_params])[:, None]
    delta = run.mesh_state.values[:, :2]
    return (np.abs(delta) > backlash) | (backlash <= 0.0)


# ------------------------------------------------------------------------- drawing


def setpoint_series(run: RecordedRun) -> tuple[np.ndarray, np.ndarray]:
    """(times s, setpoint rad) as recorded, a step function held to the end of the run;
    empty without a recorded setpoint."""
    sp = run.setpoint
    if not len(sp):
        return np.empty(0), np.empty(0)
    steps = np.append(sp.steps, max(run.end_step, int(sp.steps[-1])))
    values = sp.values[:, 0]
    return steps * run.dt, np.append(values, values[-1])


def tracking_error(run: RecordedRun) -> tuple[np.ndarray, np.ndarray]:
    """(times s, setpoint − θ2 rad) at every joint_states sample from the first recorded
    setpoint on: the setpoint recorded at a sample's step is the one the controller
    computed from that sample, so it is paired with it (a zero-order hold after)."""
    sp, js = run.setpoint, run.true_joint_states
    if not len(sp):
        return np.empty(0), np.empty(0)
    index = np.searchsorted(sp.steps, js.steps, side='right') - 1
    known = index >= 0
    error = sp.values[index[known], 0] - js.values[known, 1]
    return js.steps[known] * run.dt, error
