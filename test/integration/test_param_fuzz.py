"""Every parameter at every extreme: refused with a reason or accepted with everything
derived from it finite, in-process, at the node's start and at run time over DDS.

The extremes: 0, ±5e-324 (the smallest double), ±1e-300, ±1e300, ±inf, NaN, an
integer, a string, a bool, lists of the wrong length or type, 10⁵ elements. The
in-process family is exhaustive; the run-time family sends every case, as `ros2 param
set` does, to ONE node process; the start-time family starts a handful of processes,
the issue's cases and a seeded sample of the rest.
"""

from __future__ import annotations

import math
import os
import random
import re
import xml.etree.ElementTree as ET

import pytest
from ros_procs import STARTUP_TIMEOUT, Peer, start_process, wait_until

from screwgear_ros.numerics.stability import max_stable_dt
from screwgear_ros.params.declarations import EXCERPT_CHARS, Kind, yaml_value
from screwgear_ros.params.table import ParameterError
from screwgear_ros.physics.quantities import equivalent_mass, natural_frequency
from screwgear_ros.sim.parameter_set import default_values, split_parameters

NODE = '/table_sim'
SEED = 20
HUGE = 100_000
SCALARS = (0.0, 5e-324, -5e-324, 1e-300, -1e-300, 1e300, -1e300, math.inf, -math.inf,
           math.nan, 46, -1, 'x', True)
LISTS = ([], [1e-6] * 2, [1e-6] * 3, [5e-324], [1e300], [math.nan], [math.inf], ['x'],
         [1e-6] * HUGE)


def _parameters():
    from screwgear_ros.ros.parameters import PARAMETERS
    return PARAMETERS


def extremes(p) -> tuple:
    """The values tried on parameter ``p``: every scalar, and lists for list parameters."""
    return SCALARS + LISTS if p.kind in (Kind.FLOATS, Kind.STRINGS) else SCALARS + LISTS[1:3]


def _cases():
    return [(p, v) for p in _parameters() for v in extremes(p)]


def _derived_are_finite(values: dict) -> None:
    """Everything the node derives from a parameter set, computed and finite."""
    from screwgear_ros.physics.packed import pack
    from screwgear_ros.sim.pacing import wall_period
    from screwgear_ros.view.urdf import robot_description
    params, settings = split_parameters(values)
    assert 0.0 < max_stable_dt(params) < math.inf
    for x in (equivalent_mass(params), natural_frequency(params)):
        assert 1e-300 < x < math.inf, x         # neither underflows nor overflows
    period = wall_period(settings.steps_per_publish * settings.dt, settings.real_time_factor)
    assert all(math.isfinite(x) for x in (period, *pack(params).p))
    urdf = robot_description(params, settings, '/joint_commands', '/joint_states')
    numbers = [float(t) for el in ET.fromstring(urdf).iter() for k, t in el.attrib.items()
               for t in t.split() if k not in ('name', 'link', 'rgba') and
               re.fullmatch(r'[-+0-9.e]+', t)]
    assert numbers and all(math.isfinite(x) for x in numbers)


def test_every_extreme_is_refused_with_a_short_reason_or_everything_derived_is_finite():
    defaults = default_values()
    accepted = 0
    for p, value in _cases():
        shown = value if not isinstance(value, float) or math.isfinite(value) else repr(value)
        try:
            _derived_are_finite({**defaults, p.name: value})
            accepted += 1
        except ParameterError as error:
            assert error.name and error.rule, (p.name, shown)
            assert len(str(error)) < 2 * EXCERPT_CHARS + 400, (p.name, len(str(error)))
    assert 0 < accepted < len(_cases())


# ---------------------------------------------------------------- at run time

def _ros_value(value):
    """What `ros2 param set` would send: lists stay lists, floats floats."""
    return list(value) if isinstance(value, (list, tuple)) else value


@pytest.fixture(scope='module')
def node():
    with start_process('table_sim', params={'command_timeout': 0.0}) as proc, \
            Peer('test_param_fuzz') as peer:
        from sensor_msgs.msg import JointState
        states = peer.subscribe('/joint_states', JointState)
        states.wait_for(lambda m: True, STARTUP_TIMEOUT, 'first joint_states')
        yield proc, peer, states


@pytest.mark.ros
def test_every_extreme_set_at_run_time_gets_a_reply_and_the_node_lives(node):
    from rclpy.parameter import Parameter
    proc, peer, states = node
    client = peer._param_client(NODE, 10.0)
    defaults = default_values()
    refused = accepted = 0

    def set_one(name, value):
        future = client.set_parameters([Parameter(name, value=value)])
        wait_until(future.done, 30.0, f'a reply to setting {name}')
        (result,) = future.result().results
        return result

    for p, value in _cases():
        result = set_one(p.name, _ros_value(value))
        if result.successful:
            accepted += 1
            assert set_one(p.name, _ros_value(defaults[p.name])).successful, p.name
        else:
            refused += 1
            assert result.reason, (p.name, value)
        assert proc.alive(), f'table_sim died setting {p.name}:\n{proc.output()[1][-3000:]}'
    assert refused and accepted
    # the node still runs, with every value in force as it was
    names = [p.name for p in _parameters()]
    assert peer.get_parameters(NODE, names) == defaults
    before = len(states.snapshot())
    wait_until(lambda: len(states.snapshot()) > before + 10, 30.0, 'joint_states flowing')
    stderr = proc.output()[1]
    assert 'Traceback' not in stderr and 'FATAL' not in stderr, stderr[-3000:]
    assert max(map(len, stderr.splitlines() or [''])) < 2000    # no list of 10⁵ in a line


# ---------------------------------------------------------------- at start

def _yaml_text(value) -> str:
    """``value`` as YAML 1.1 text for ``-p name:=value``."""
    if isinstance(value, float) and not math.isfinite(value):
        return '.nan' if math.isnan(value) else '.inf' if value > 0 else '-.inf'
    return yaml_value(value)


#: The issue's cases, and a value of a wrong type and of 10⁵ elements.
START_CASES = [('radius_table', 1.0e-200), ('real_time_factor', 1.0e-20),
               ('publish_rate', 1.0e-300), ('ste_amplitudes', 1.0)]


def _refused_at_start() -> list[tuple[str, object]]:
    """The issue's start cases and a seeded sample of the scalar extremes the core
    refuses (the node refuses what split_parameters refuses, or what is of the wrong
    type for rclpy)."""
    defaults = default_values()
    pool = []
    for p, value in _cases():
        if isinstance(value, list) or (p.kind is Kind.FLOAT and isinstance(value, int)
                                       and not isinstance(value, bool)):
            continue
        try:
            split_parameters({**defaults, p.name: value})
        except ParameterError:
            pool.append((p.name, value))
    return START_CASES + random.Random(SEED).sample(pool, 3)


@pytest.mark.ros
def test_an_extreme_at_start_exits_2_with_the_reason_and_no_traceback(tmp_path):
    cases = _refused_at_start()
    procs = [start_process('table_sim', ros_args=['-p', f'{name}:={_yaml_text(value)}'],
                           workdir=tmp_path / f'case{i}') for i, (name, value) in
             enumerate(cases)]
    huge = start_process('table_sim', params={'ste_phases': [0.0] * HUGE},
                         workdir=tmp_path / 'huge')
    # the starts share the cores: each may take as long as all of them on one core
    started = [*zip(cases, procs, strict=True), (('ste_phases', 'huge'), huge)]
    timeout = STARTUP_TIMEOUT * max(1.0, len(started) / (os.cpu_count() or 1))
    try:
        for (name, value), proc in started:
            wait_until(lambda proc=proc: not proc.alive(), timeout, f'table_sim to refuse {name}')
            stderr = proc.output()[1]
            assert proc.popen.returncode == 2, (name, value, stderr[-2000:])
            assert 'cannot start' in stderr and name in stderr, (name, value, stderr[-2000:])
            assert 'Traceback' not in stderr, stderr[-3000:]
            assert max(map(len, stderr.splitlines())) < 2000
    finally:
        for proc in (*procs, huge):
            proc.kill()
