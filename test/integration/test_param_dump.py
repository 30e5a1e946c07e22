"""table_sim --dump-params: a parameter file that --params-file reads back exactly.

Checked against the two readers of a parameter file, not against our own reader:
rcl's parser (what ``--params-file`` runs, here through rclpy in a private context)
and PyYAML's YAML 1.1 (what ``ros2 param load`` and launch read). Values are compared
bit for bit (``float.hex``). Then end to end: a running table_sim writes its file, a
parameter set at run time rewrites it, and a second table_sim started from it has
every parameter of the first.
"""

from __future__ import annotations

import math
import random
import struct
import sys

import pytest
import yaml
from ros_procs import Peer, start_process, wait_until

from screwgear_ros.ros import param_dump

TINY = (1e-300, 7.5e-05, 1e-06, 1e-05, 2.5e-07, sys.float_info.min, -sys.float_info.min,
        sys.float_info.max, -0.0, 0.1, 1e16, 123456789.0, 5e-300)


def _key(value):
    """A value's identity: its type and, for floats, its bits (-0.0 != 0.0; any NaN is
    NaN: its sign and payload mean nothing to a parameter)."""
    if isinstance(value, float) and math.isnan(value):
        return ('float', 'nan')
    if isinstance(value, float):
        return ('float', struct.pack('<d', value))
    if isinstance(value, (list, tuple)):
        return ('list', tuple(_key(v) for v in value))
    return (type(value).__name__, value)


def _random_double(rng: random.Random) -> float:
    """A finite normal double from random bits (subnormals are unwritable; the
    non-finite ones are in _values once each)."""
    while True:
        x = struct.unpack('<d', rng.getrandbits(64).to_bytes(8, 'little'))[0]
        if math.isfinite(x) and (x == 0.0 or abs(x) >= sys.float_info.min):
            return x


def _values(seed: int) -> dict:
    rng = random.Random(seed)
    values = {f'tiny_{i}': x for i, x in enumerate(TINY)}
    values.update({f'bits_{i}': _random_double(rng) for i in range(40)})
    values.update({'inf': math.inf, 'minus_inf': -math.inf, 'nan': math.nan,
                   'flag': True, 'off': False, 'count': 7, 'big': 2 ** 63 - 1,
                   'small': -2 ** 63, 'zero_int': 0,
                   'doubles': [1e-06, 7.5e-05, 1e-300, rng.uniform(-1, 1), 2.0],
                   'ints': [1, -2, 3], 'bools': [True, False],
                   'texts': ['x', '', '12', 'true', "it's", 'a"b', 'ü', '# no', 'k: v'],
                   'text_number': '1e-06', 'text_bool': 'false', 'text_empty': '',
                   'text_null': 'null', 'text_newline': 'two\nlines',
                   'nested.inner': 2.5e-07, 'y': 1, 'null': 'x', 'yes.no': False})
    return values


def _read_with_rcl(path) -> dict:
    """What --params-file gives a node: rcl parses the file, rclpy declares it."""
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions
    context = Context()
    rclpy.init(args=['reader', '--ros-args', '--params-file', str(path)], context=context,
               signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('reader', context=context,
                                 automatically_declare_parameters_from_overrides=True)
        bare = rclpy.create_node('bare', context=context)    # what every node has
        try:
            own = set(param_dump.node_values(bare))
            return {k: v for k, v in param_dump.node_values(node).items() if k not in own}
        finally:
            bare.destroy_node()
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_rcl_and_yaml_1_1_read_the_file_back_bit_for_bit(seed, tmp_path):
    values = _values(seed)
    path = tmp_path / 'dump.yaml'
    assert param_dump.write(path, values) == []
    by_rcl = _read_with_rcl(path)
    assert {k: _key(v) for k, v in by_rcl.items()} == {k: _key(v) for k, v in values.items()}
    tree = yaml.safe_load(path.read_text(encoding='utf-8'))
    assert list(tree) == [param_dump.WILDCARD]
    flat = dict(tree[param_dump.WILDCARD]['ros__parameters'])
    flat['nested.inner'] = flat.pop('nested')['inner']
    flat['yes.no'] = flat.pop('yes')['no']
    assert {k: _key(v) for k, v in flat.items()} == {k: _key(v) for k, v in values.items()}


def test_what_no_parameter_file_can_carry_is_left_out_and_named(tmp_path):
    subnormal = sys.float_info.min / 2 ** 10
    values = {'ok': 1e-06, 'subnormal': subnormal, 'in_list': [1.0, 5e-324], 'empty': [],
              'raw': b'\x01', 'record': '/tmp/run1'}
    path = tmp_path / 'dump.yaml'
    left_out = dict(param_dump.write(path, values))
    assert sorted(left_out) == ['empty', 'in_list', 'raw', 'record', 'subnormal']
    text = path.read_text(encoding='utf-8')
    for name in left_out:                      # said in the file, not written as a value
        assert f'# left out: {name}:' in text
    assert _read_with_rcl(path) == {'ok': 1e-06}


def test_a_file_that_cannot_be_written_leaves_the_old_one_whole(tmp_path):
    path = tmp_path / 'dump.yaml'
    param_dump.write(path, {'a': 1.0})
    before = path.read_text(encoding='utf-8')
    with pytest.raises(OSError):
        param_dump.write(tmp_path / 'missing_dir' / 'dump.yaml', {'a': 2.0})
    assert path.read_text(encoding='utf-8') == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ['dump.yaml']   # no temp left


# ------------------------------------------------------------------ table_sim end to end

STARTED = {'thermal_coefficient': 1e-300, 'backlash': 7.5e-05,
           'ste_amplitudes': [1e-06, 2.5e-07], 'ste_phases': [0.0, 1e-300],
           'mesh_stiffness_phase': 0.1, 'publish_clock': False}
SET_AT_RUN_TIME = {'table_damping': 1e-05}


def _all_parameters(peer: Peer, node: str) -> dict:
    from rcl_interfaces.srv import ListParameters
    names = peer.call(ListParameters, f'{node}/list_parameters', timeout=60.0).result.names
    return peer.get_parameters(node, names)


@pytest.mark.ros
def test_a_running_table_dumps_and_a_restart_from_the_dump_has_every_value(tmp_path):
    dump = tmp_path / 'table.yaml'
    first = start_process('table_sim', params=STARTED, args=['--dump-params', str(dump)],
                          ros_args=['-r', '__ns:=/original'], workdir=tmp_path / 'first')
    second = None
    try:
        with Peer('dump_peer') as peer:
            wait_until(dump.exists, 60.0, 'the dump at start')
            results = peer.set_parameters('/original/table_sim', SET_AT_RUN_TIME)
            assert all(r.successful for r in results), results
            wait_until(lambda: 'table_damping: 1.0e-05' in dump.read_text(encoding='utf-8'),
                       10.0, 'the dump rewritten after the set')
            original = _all_parameters(peer, '/original/table_sim')
            second = start_process('table_sim', params_file=dump,
                                   ros_args=['-r', '__ns:=/restored'],
                                   workdir=tmp_path / 'second')
            restored = _all_parameters(peer, '/restored/table_sim')
    finally:
        for proc in (first, second):
            if proc is not None:
                proc.stop()
    for name, value in {**STARTED, **SET_AT_RUN_TIME}.items():
        assert _key(original[name]) == _key(value), name
    assert {n: _key(v) for n, v in restored.items()} == \
        {n: _key(v) for n, v in original.items()}
    assert 'Traceback' not in first.output()[1] + second.output()[1]


@pytest.mark.ros
def test_an_unwritable_dump_path_refuses_to_start_with_the_reason(tmp_path):
    target = tmp_path / 'no_such_dir' / 'table.yaml'
    proc = start_process('table_sim', args=['--dump-params', str(target)],
                         workdir=tmp_path / 'run')
    try:
        proc.popen.wait(timeout=60)
    finally:
        proc.stop()
    _, stderr = proc.output()
    assert proc.popen.returncode == 2, stderr[-2000:]
    assert f'--dump-params {target}' in stderr and 'Traceback' not in stderr
