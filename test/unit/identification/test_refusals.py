"""What ``identify`` refuses before it fits, as a user meets it: seeded fuzz families of
its arguments, of damaged bags and of base files, each through the command line
in-process (exit 2, one line naming the argument and the rule, no internal error's text,
nothing written, the recordings and the base file untouched), all on one tiny recording
made here (0.4 s, one reversal)."""

from __future__ import annotations

import copy
import hashlib
import random
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from identify_truth import truth_simulation, write_base

from screwgear_ros.cli.identify import main
from screwgear_ros.identification.adapter import base_values, simulate
from screwgear_ros.identification.recording import read_recording
from screwgear_ros.inprocess.simulation import Simulation

SEED = 4317
BUDGET = 60.0
INTERNAL = ('Error:', 'Traceback', 'internal error', 'index ', 'object has no attribute')


def _messages(bag: Path) -> list[tuple[str, str, int, Any]]:
    from rosbags.highlevel import AnyReader

    from screwgear_ros.bag.format import typestore
    with AnyReader([bag], default_typestore=typestore()) as reader:
        return [(c.topic, c.msgtype, stamp, reader.deserialize(raw, c.msgtype))
                for c, stamp, raw in reader.messages(connections=reader.connections)]


def write_bag(dst: Path, messages: Iterable[tuple[str, str, int, Any]]) -> Path:
    """A bag of ``messages`` (topic, type, log time, message), rosbags' writer."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    from screwgear_ros.bag.format import typestore
    store = typestore()
    with Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections: dict[tuple[str, str], Any] = {}
        for topic, msgtype, stamp, message in messages:
            if (topic, msgtype) not in connections:
                connections[topic, msgtype] = writer.add_connection(topic, msgtype,
                                                                    typestore=store)
            writer.write(connections[topic, msgtype], stamp,
                         store.serialize_cdr(message, msgtype))
    return dst


def _edit(messages: list[tuple[str, str, int, Any]], topic: str,
          change: Callable[[Any], Any]) -> list[tuple[str, str, int, Any]]:
    return [(t, m, s, change(x) if t.endswith(topic) else x) for t, m, s, x in messages]


@pytest.fixture(scope='module')
def tiny(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    root = tmp_path_factory.mktemp('refusals')
    bag = root / 'tiny'
    truth_simulation().run(lambda o: 5.0 if o.time < 0.2 else -5.0, 0.4, record=bag)
    base = write_base(root / 'base.yaml', ['inertia_table'])
    return {'root': root, 'bag': bag, 'base': base, 'messages': _messages(bag)}


def _digest(*paths: Path) -> str:
    h = hashlib.sha256()
    for path in paths:
        for f in sorted(p for p in ([path] if path.is_file() else path.rglob('*'))
                        if p.is_file()):
            h.update(f.read_bytes())
    return h.hexdigest()


def _refused(capsys: pytest.CaptureFixture[str], argv: list[str], rule: str, where: str,
             untouched: Iterable[Path] = ()) -> None:
    untouched = list(untouched)
    before = _digest(*untouched) if untouched else ''
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exit_:          # argparse's own refusal of a malformed line
        code = exit_.code
    err = capsys.readouterr().err
    assert code == 2, f'{where}: exit {code}, {err!r}'
    assert 'identify: ' in err and rule in err, f'{where}: {err!r} does not say {rule!r}'
    assert not any(text in err for text in INTERNAL), f'{where}: internal text in {err!r}'
    if untouched:
        assert _digest(*untouched) == before, f'{where}: an input was changed'


def _argument_case(rng: random.Random, tiny: dict[str, Any]) -> tuple[list[Any], str]:
    bag, base, root = tiny['bag'], tiny['base'], tiny['root']
    big = 10 ** rng.randint(4, 15)
    cases: list[tuple[list[Any], str]] = [
        (['--workers', big], '--workers'),
        (['--workers', rng.choice(['1e12', '2.5', 'many'])], '--workers'),
        (['--seed', -rng.randint(1, 10 ** 9)], '--seed'),
        (['--scheduler', rng.choice(['garbage', 'tcp://host', 'tcp://h:99999', ':1'])],
         '--scheduler'),
        (['--starts', big], '--starts'),
        (['--max-evaluations', rng.choice([0, -1, big])], '--max-evaluations'),
        (['--input-delay', rng.randint(399, 10 ** 7)], '--input-delay'),
        (['--bounds', 'inertia_table=10:90', f'inertia_table={rng.randint(1, 9)}:99'],
         'twice'),
        (['--joints', rng.choice(['pinion_1=table', 'pinion_1=x,table=x,pinion_3=x',
                                  'pinion_3=pinion_1'])], 'both read'),
        (['-o', bag / rng.choice(['metadata.yaml', 'tiny_0.mcap', 'new.yaml'])], 'recording'),
        (['-o', root / 'fitted.yaml', '--report', bag / 'report'], 'recording'),
        (['-o', base], 'base file'),
        (['-o', root], 'folder'),
        (['--bounds', f'inertia_table={rng.uniform(50, 60)}:{rng.uniform(10, 40)}'], 'LO < HI'),
        (['--fit', rng.choice(['thermal_coefficient', 'table_damping'])], 'no range'),
        (['--fit', 'radius_pinion_1'], 'refuses every value'),
        (['--fit', 'drive_time_constant', '--bounds',
          f'drive_time_constant={rng.uniform(1.0, 1.5):.3f}e-6:3e-6'], 'refuses every value'),
    ]
    argv, rule = rng.choice(cases)
    if '--fit' not in argv:
        argv = [*argv, '--fit', 'inertia_table']
    if '-o' not in argv:
        argv = [*argv, '-o', root / 'fitted.yaml']
    return [bag, '--params', base, '--no-progress', *argv], rule


def test_arguments_out_of_their_rules_are_refused_before_anything_is_written(tiny, capsys):
    rng = random.Random(SEED)
    started = time.monotonic()
    for case in range(60):
        argv, rule = _argument_case(rng, tiny)
        _refused(capsys, argv, rule, f'seed {SEED} case {case}: {argv[4:]}',
                 [tiny['bag'], tiny['base']])
        assert not (tiny['root'] / 'fitted.yaml').exists(), f'seed {SEED} case {case}'
        assert not list(tiny['root'].glob('.*.partial')), f'seed {SEED} case {case}'
        assert time.monotonic() - started < BUDGET, f'seed {SEED}: over budget at {case}'


def _damaged(rng: random.Random, messages: list[tuple[str, str, int, Any]]
             ) -> tuple[list[tuple[str, str, int, Any]], list[str], str]:
    """A damaged copy of ``messages``, extra arguments, and the rule its refusal names."""
    from screwgear_ros.bag.format import typestore
    store = typestore()
    kind = rng.randrange(5)
    if kind == 0:        # positions shorter than the names
        keep = rng.randint(0, 2)

        def short(m: Any) -> Any:
            m.position = m.position[:keep]
            return m
        return _edit(messages, 'joint_states', short), [], 'positions'
    if kind == 1:        # joint_states of another type
        text = store.types['std_msgs/msg/String']
        out = [(t, k, s, x) for t, k, s, x in messages if not t.endswith('joint_states')]
        out += [('/joint_states', 'std_msgs/msg/String', s, text(data='x'))
                for t, _, s, _ in messages if t.endswith('joint_states')]
        return out, [], 'std_msgs/msg/String'
    if kind == 2:        # two tables in one bag
        spaces = rng.sample(['/axis_a', '/axis_b', '/left', '/x/y'], 2)
        return [(f'{ns}{t}', k, s, x) for ns in spaces for t, k, s, x in messages], [], \
            '--namespace'
    if kind == 3:        # a command logged before the first state
        first = min(s for t, _, s, _ in messages if t.endswith('joint_states'))
        effort = next(x for t, _, _, x in messages if t.endswith('cmd_effort'))
        ahead = rng.randint(2, 500) * 1_000_000
        return [('/cmd_effort', 'std_msgs/msg/Float64MultiArray', first - ahead, effort),
                *messages], [], 'before the first joint_states'

    def still(m: Any) -> Any:   # no velocities, and --speeds
        m.velocity = np.array([], dtype=np.float64)
        return m
    return _edit(messages, 'joint_states', still), ['--speeds'], 'records no velocity'


def test_damaged_bags_are_refused_naming_the_bag_and_the_rule(tiny, capsys, tmp_path):
    rng = random.Random(SEED + 1)
    started = time.monotonic()
    for case in range(12):
        messages = copy.deepcopy([(t, k, s, x) for t, k, s, x in tiny['messages']
                                  if t.endswith(('joint_states', 'cmd_effort'))])
        damaged, extra, rule = _damaged(rng, messages)
        bag = write_bag(tmp_path / f'bag{case}', damaged)
        _refused(capsys, [bag, '--params', tiny['base'], '--fit', 'inertia_table',
                          '--no-progress', *extra, '-o', tmp_path / 'fitted.yaml'],
                 rule, f'seed {SEED + 1} case {case} ({rule})', [bag])
        assert not (tmp_path / 'fitted.yaml').exists(), f'seed {SEED + 1} case {case}'
        assert time.monotonic() - started < BUDGET, f'seed {SEED + 1}: over budget at {case}'


def _base_file(rng: random.Random, path: Path) -> tuple[str, str]:
    kind = rng.randrange(3)
    value = rng.uniform(30.0, 60.0)
    if kind == 0:
        return (f'/**: {{ros__parameters: {{inertia_table: {value}, command_timeout: 0.0}}}}\n',
                'block-style')
    if kind == 1:
        # the node merges the blocks in order: the second block's value is the one in force
        return ((f'/**:\n  ros__parameters:\n    inertia_table: {value}\n'
                f'table_sim:\n  ros__parameters:\n    inertia_table: {value + 1}\n'),
                'block-style')
    return ((f'/**:\n  ros__parameters:\n    inertia_table: {value}\n    radius_pinion_3: '
            f'{rng.uniform(0.01, 0.07):.4f}\n'), 'radius_pinion_3')


def test_base_files_the_fit_could_not_write_into_are_refused_before_the_fit(tiny, capsys,
                                                                            tmp_path):
    rng = random.Random(SEED + 2)
    for case in range(9):
        text, rule = _base_file(rng, tmp_path / 'base.yaml')
        base = tmp_path / f'base{case}.yaml'
        base.write_text(text, encoding='utf-8')
        _refused(capsys, [tiny['bag'], '--params', base, '--fit', 'inertia_table',
                          '--no-progress', '-o', tmp_path / 'fitted.yaml'],
                 rule, f'seed {SEED + 2} case {case} ({text!r})', [base])
        assert not list(tmp_path.glob('*fitted*')), f'seed {SEED + 2} case {case}'


def test_one_table_of_a_bag_with_two_is_read_by_its_namespace(tiny, tmp_path):
    messages = [(t, k, s, x) for t, k, s, x in tiny['messages']
                if t.endswith(('joint_states', 'cmd_effort'))]
    bag = write_bag(tmp_path / 'two', [(f'{ns}{t}', k, s, x) for ns in ('/a', '/b')
                                       for t, k, s, x in messages])
    alone = read_recording(tiny['bag'])
    for ns in ('/a', 'b'):
        chosen = read_recording(bag, namespace=ns)
        np.testing.assert_array_equal(chosen.position, alone.position)
        assert chosen.inputs == alone.inputs


def test_the_joint_names_error_lists_the_recorded_order(tiny, tmp_path):
    names = ['zeta', 'alpha', 'mid']

    def rename(m: Any) -> Any:
        m.name = names
        return m
    messages = copy.deepcopy([(t, k, s, x) for t, k, s, x in tiny['messages']
                              if t.endswith(('joint_states', 'cmd_effort'))])
    bag = write_bag(tmp_path / 'renamed', _edit(messages, 'joint_states', rename))
    with pytest.raises(ValueError, match=r"\['zeta', 'alpha', 'mid'\]"):
        read_recording(bag)


def test_reversals_are_those_the_node_applied(tiny, tmp_path):
    """An effort inside effort_deadband keeps the direction: no reversal (the node's
    rule, docs: effort_deadband), whatever its sign."""
    base = base_values(tiny['base'])
    deadband = Simulation.from_yaml(tiny['base']).params.effort_deadband
    forward = tmp_path / 'forward'
    truth_simulation().run(lambda o: -0.5 * deadband if 0.1 < o.time < 0.11 else 5.0, 0.3,
                           record=forward)
    counts: list[int] = []
    simulate(base, read_recording(forward), reversals=counts)
    simulate(base, read_recording(tiny['bag']), reversals=counts)
    assert counts == [0, 1], counts


def test_a_command_within_a_tick_before_the_first_sample_acts_from_it(tiny, tmp_path):
    """The rule of #43 on #46's time model: a command logged up to one tick before the
    first sample (the recorder missed that sample) acts from the first sample's time,
    where the simulation starts; one logged earlier is refused."""
    from screwgear_ros.identification.errors import RecordingError
    # a second later: the node's own bag starts at log time 0, a bag holds no earlier one
    later = [(t, k, s + 1_000_000_000, x) for t, k, s, x in tiny['messages']]
    plain = read_recording(write_bag(tmp_path / 'later', later))
    period = plain.period * 1e9
    effort = next(x for t, _, _, x in tiny['messages'] if t.endswith('cmd_effort'))
    for ahead, kept in ((0.5, True), (0.99, True), (1.5, False), (40.0, False)):
        stamp = int(plain.times[0]) - round(ahead * period)
        bag = write_bag(tmp_path / f'ahead{ahead}', [
            ('/cmd_effort', 'std_msgs/msg/Float64MultiArray', stamp, effort), *later])
        if kept:
            read = read_recording(bag)
            assert read.origin == read.times[0] == plain.times[0], ahead
            assert read.inputs[0][0] == read.times[0], ahead
        else:
            with pytest.raises(RecordingError, match='before the first joint_states'):
                read_recording(bag)


def test_an_exponent_without_a_point_is_a_double_as_rcl_reads_it(tmp_path):
    plain, pointed = tmp_path / 'plain.yaml', tmp_path / 'pointed.yaml'
    plain.write_text('/**:\n  ros__parameters:\n    effort_deadband: 2e-06\n', encoding='utf-8')
    pointed.write_text('/**:\n  ros__parameters:\n    effort_deadband: 2.0e-06\n',
                       encoding='utf-8')
    assert Simulation.from_yaml(plain).params == Simulation.from_yaml(pointed).params
    assert base_values(plain) == base_values(pointed) == {'effort_deadband': 2e-06}


def test_the_api_s_keyword_arguments_out_of_their_rules_are_refused(tiny):
    """The in-process ``identify``: each hostile keyword is an IdentifyError that names
    it, before any bag is read."""
    from screwgear_ros import IdentifyError, identify
    rng = random.Random(SEED + 3)
    kinds: list[tuple[str, Callable[[], Any], str]] = [
        ('workers', lambda: rng.choice([0, True, 1e12, '2', 10 ** 12, None]), '--workers'),
        ('seed', lambda: rng.choice([-5, 2.5, 'x', None]), '--seed'),
        ('starts_count', lambda: rng.choice([0, 10 ** 12, 1e3, [3]]), '--starts'),
        ('max_evaluations', lambda: rng.choice([0, -3, 10 ** 9, 'many']), '--max-evaluations'),
        ('input_delay', lambda: rng.choice([-1, float('nan'), float('inf'), 'one']),
         '--input-delay'),   # a fraction of a tick is a delay (issue #46)
        ('scheduler', lambda: rng.choice(['garbage', 42, 'tcp://:', 'tcp://a:0']), '--scheduler'),
        ('bounds', lambda: {'inertia_table': rng.choice(['x', (1,), (5, 1), (0, float('nan')),
                                                         None])}, 'bounds'),
        ('fit', lambda: rng.choice(['inertia_table', [3.5], []]), 'fit'),
    ]
    for case in range(40):
        name, value, rule = rng.choice(kinds)
        kwargs = {'fit': ['inertia_table'], name: value()}
        fit = kwargs.pop('fit')
        with pytest.raises(IdentifyError) as caught:
            identify([tiny['bag']], tiny['base'], fit, **kwargs)
        assert rule in str(caught.value), f'seed {SEED + 3} case {case}: {name}={kwargs}: ' \
            f'{caught.value}'
