"""record_session advances its session through Session.advance, the one way to advance:
the bag is message for message, byte for byte, the one the explicit loop records (each
event submitted once the outputs of its step are out, a change rendered first when
prepared). And the recording needs no ROS message package: every message is CDR
written by the package itself."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader

from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.runs.session_record import SessionRecording, record_session
from screwgear_ros.sim.events import Command, ParameterChange, Reset, Setpoint
from screwgear_ros.sim.schedule import Schedule
from screwgear_ros.sim.session import Session


def _schedule() -> Schedule:
    p = TableParams(table_damping=8867.0)
    s = SimSettings(publish_rate=500.0, encoder_counts_table=4096)   # ~/true_joint_states too
    noisy = SimSettings(publish_rate=500.0, position_noise_table=1e-5, sensor_seed=3)
    return Schedule(p, s, [
        Command('cmd_torque', 300.0, 0), Setpoint(0.01, 0), Command('cmd_direction', -1, 200),
        ParameterChange(p.replace(mesh_damping=900.0), noisy, 400), Reset(600),
        ParameterChange(p.replace(radius_table=0.62), s, 800),
        Command('load_torque', 20.0, 1000)], end_step=1400)


def _by_loop(path: Path, schedule: Schedule, prepare: bool) -> None:
    """The explicit loop record_session ran before it advanced through Session.advance."""
    session = Session(schedule.params, schedule.settings)
    with SessionRecording(path, session) as recording:
        while session.step < schedule.end_step:
            for event in schedule.due(session.step):
                if prepare and isinstance(event, ParameterChange):
                    recording.submit_change(event)
                else:
                    session.submit(event)
            recording.tick(session.tick())


def _messages(bag: Path) -> list[tuple[str, int, bytes]]:
    """Every message but table_markers (paced by wall time), raw."""
    mcap_file, = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        return [(channel.topic, message.log_time, bytes(message.data))
                for _, channel, message in make_reader(stream).iter_messages(
                    log_time_order=False) if channel.topic != '/table_markers']


@pytest.mark.parametrize('prepare', [False, True])
def test_advance_records_the_bag_the_explicit_loop_records(tmp_path, prepare):
    record_session(tmp_path / 'advance', _schedule(), prepare=prepare)
    _by_loop(tmp_path / 'loop', _schedule(), prepare)
    advanced, looped = _messages(tmp_path / 'advance'), _messages(tmp_path / 'loop')
    assert advanced == looped
    topics = {topic for topic, _, _ in advanced}
    assert {'/table_sim/run_parameters', '/table_sim/reset', '/cmd_torque', '/cmd_direction',
            '/load_torque', '/setpoint', '/active_path', '/robot_description',
            '/table_sim/true_joint_states'} <= topics


def test_a_recording_refuses_a_tick_it_cannot_see(tmp_path):
    session = Session(TableParams(), SimSettings())
    with SessionRecording(tmp_path / 'bag', session) as recording, \
            pytest.raises(ValueError, match='every tick'):
        recording.tick(None)
