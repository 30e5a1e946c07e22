"""table_sim through the real ``ros2`` command line: what a user types, against a real node.

The ros2 CLI runs from the tests' own overlay (test/support/ros2cli.py); where its wheels
are not found, every test here is skipped with the reason. The node is started with
``ros2 run`` (one node for the module, a parameter file giving it a mark); what the
verbs print is checked against the tables of docs/topics.md and docs/parameters.md and
the package's metadata, not against the node's own code.
"""

from __future__ import annotations

import ast
import importlib
import importlib.metadata
import math
import re
from concurrent.futures import ThreadPoolExecutor

import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from paths import ROOT
from ros2cli import (
    NEEDS_OVERLAY,
    kill_group,
    overlay,
    ros2cli_overlay,  # noqa: F401  (the fixture NEEDS_OVERLAY uses)
    stop_group,
)
from ros_procs import STARTUP_TIMEOUT, Peer, wait_until, write_params_file
from sensor_msgs.msg import JointState

pytestmark = [pytest.mark.ros, *NEEDS_OVERLAY]

PACKAGE = 'screwgear_ros'
NODE = '/table_sim'
DOCS = ROOT / 'docs'
PAPER = yaml.safe_load((ROOT / 'config' / 'paper.yaml').read_text())['/**']['ros__parameters']
#: The module node's parameter file: a mark that ``ros2 run --params-file`` applied it.
MARKED_DAMPING = 650.5
LOG_ERRORS = ('Traceback', '[ERROR]', '[FATAL]')


def doc_table(marker: str) -> list[list[str]]:
    """The rows of the table after ``<!-- {marker}: ...`` in docs/{marker}.md (cells,
    backticks off)."""
    text = (DOCS / f'{marker}.md').read_text(encoding='utf-8')
    block = text.split(f'<!-- {marker}:', 1)[1].split('<!-- end', 1)[0]
    rows = [line for line in block.splitlines() if line.startswith('| `')]
    cells = [[c.strip().strip('`') for c in re.split(r'(?<!\\)\|', row)[1:-1]] for row in rows]
    # the last cell (meaning) may hold a bare | (|ω| in a formula): it is one cell
    width = min(map(len, cells))
    return [[*row[:width - 1], '|'.join(row[width - 1:])] for row in cells]


def topic_rows() -> list[tuple[str, str, str]]:
    """(resolved name, ros2 type, direction) of every docs/topics.md row."""
    out = []
    for name, kind, direction, *_ in doc_table('topics'):
        resolved = (NODE + name[1:] if name.startswith('~') else
                    name if name.startswith('/') else '/' + name)
        package, _, message = kind.partition('/')
        folder = 'srv' if direction == 'service' else 'msg'
        out.append((resolved, f'{package}/{folder}/{message}', direction))
    return out


class Node:
    """The module's node, its log and a peer reading its diagnostics."""

    def __init__(self, proc, peer, diag, states):
        self.proc, self.peer, self.diag, self.states = proc, peer, diag, states

    def log(self) -> str:
        return ''.join(self.proc.output())

    def rejected(self, topic: str) -> int:
        """rejected_<topic> of the next diagnostics (absent: none yet)."""
        msg = self.diag.wait_next(lambda m: True, 15.0, 'diagnostics')
        values = {kv.key: kv.value for s in msg.status for kv in s.values}
        assert 'rejected_inputs' in values, values
        return int(values.get(f'rejected_{topic}', '0'))


@pytest.fixture(scope='module')
def node(tmp_path_factory):
    ros2 = overlay()
    work = tmp_path_factory.mktemp('ros2cli_node')
    params = write_params_file(work / 'marked.yaml', {'mesh_damping': MARKED_DAMPING})
    proc = ros2.start('run', PACKAGE, 'table_sim', '--ros-args', '--params-file', str(params),
                      workdir=work / 'node')
    try:
        with Peer('ros2cli_test') as peer:
            states = peer.subscribe('/joint_states', JointState, transform=lambda m: None)
            diag = peer.subscribe('/diagnostics', DiagnosticArray)
            states.wait_for(lambda m: True, STARTUP_TIMEOUT, 'joint_states of table_sim')
            yield Node(proc, peer, diag, states)
        assert stop_group(proc) == 0, ''.join(proc.output())[-3000:]
        assert 'Traceback' not in ''.join(proc.output())
    finally:
        kill_group(proc)


def get(name: str, node: str = NODE):
    """A parameter's value as ``ros2 param get`` prints it, parsed."""
    text = overlay().ask('param', 'get', node, name).stdout.strip()
    value = text.split(':', 1)[1].strip()
    if text.startswith('String value is'):
        return value
    return ast.literal_eval(value)          # Python's repr: 1e-06 is no YAML 1.1 float


# ---------------------------------------------------------------- pkg, run, node, topic

def test_pkg_executables_are_the_packages_console_scripts():
    scripts = {e.name for e in importlib.metadata.entry_points(group='console_scripts')
               if e.dist is not None and e.dist.name == PACKAGE}
    lines = overlay().run('pkg', 'executables', PACKAGE).stdout.split('\n')
    assert sorted(line.split()[1] for line in lines if line.strip()) == sorted(scripts)


def test_ros2_run_applies_its_params_file(node):
    assert get('mesh_damping') == MARKED_DAMPING != PAPER['mesh_damping']


def test_ros2_run_without_a_params_file_runs_the_papers_example(tmp_path):
    ros2 = overlay()
    proc = ros2.start('run', PACKAGE, 'table_sim', '--ros-args', '-r', '__ns:=/bare',
                      workdir=tmp_path)
    try:
        for name in ('mesh_damping', 'preload_torque', 'ste_amplitudes', 'mode'):
            assert get(name, '/bare/table_sim') == PAPER[name], name
        assert stop_group(proc) == 0, ''.join(proc.output())[-3000:]
    finally:
        kill_group(proc)


def _node_info() -> dict[str, dict[str, str]]:
    """Section → {name: type} of ``ros2 node info``."""
    sections: dict[str, dict[str, str]] = {}
    current = None
    for line in overlay().ask('node', 'info', NODE).stdout.splitlines():
        if line.startswith('  ') and line.strip().endswith(':'):
            current = sections.setdefault(line.strip()[:-1], {})
        elif current is not None and ': ' in line:
            name, kind = line.strip().split(': ', 1)
            current[name] = kind
    return sections


def test_node_info_shows_the_readmes_topics_and_the_reset_service(node):
    info = _node_info()
    for name, kind, direction in topic_rows():
        if direction == 'in':
            assert info['Subscribers'].get(name) == kind, (name, info['Subscribers'])
        elif direction == 'out' and not name.endswith('true_joint_states'):  # sensors ideal
            assert info['Publishers'].get(name) == kind, (name, info['Publishers'])
        elif direction == 'service':
            assert info['Service Servers'].get(name) == kind, name


def test_topic_list_shows_every_readme_topic_with_its_type(node):
    wanted = {(name, kind) for name, kind, direction in topic_rows()
              if direction in ('in', 'out') and not name.endswith('true_joint_states')}
    last_listing = None
    for _ in range(20):                     # a new participant discovers the node
        listing = overlay().run('topic', 'list', '-t', '--no-daemon').stdout
        shown = {tuple(line.replace('[', '').replace(']', '').split())
                 for line in listing.splitlines() if line.strip()}
        if wanted <= shown:
            break
        last_listing = listing
    assert wanted <= shown, last_listing


def _fields_shown(text: str) -> set[str]:
    """The top-level field names ``ros2 interface show`` prints (constants aside)."""
    names = set()
    for line in text.splitlines():
        if not line or line[0] in ' \t#' or line.startswith('---'):
            continue
        parts = line.split('#', 1)[0].split()
        if len(parts) >= 2 and '=' not in parts[1] and '=' not in ' '.join(parts[2:3]):
            names.add(parts[1])
    return names


def _fields_of(kind: str) -> set[str]:
    package, folder, name = kind.split('/')
    cls = getattr(importlib.import_module(f'{package}.{folder}'), name)
    parts = (cls.Request, cls.Response) if folder == 'srv' else (cls,)
    return {f for part in parts for f in part.get_fields_and_field_types()}


def test_interface_show_prints_every_type_the_node_uses(node):
    kinds = {kind for section in _node_info().values() for kind in section.values()}
    assert {'std_srvs/srv/Trigger', 'sensor_msgs/msg/JointState'} <= kinds
    kinds = sorted(kinds)
    with ThreadPoolExecutor(4) as pool:        # one ros2 process a type: start-up bound
        shown = pool.map(lambda kind: overlay().run('interface', 'show', kind).stdout, kinds)
    for kind, text in zip(kinds, shown, strict=True):
        assert _fields_shown(text) == _fields_of(kind), (kind, text)


def test_service_call_reset_is_answered_and_the_log_says_the_step(node):
    done = overlay().run('service', 'call', f'{NODE}/reset', 'std_srvs/srv/Trigger',
                         timeout=60)
    assert 'success=True' in done.stdout and 'reset queued' in done.stdout, done.stdout
    wait_until(lambda: 'reset to the preload equilibrium at t =' in node.log(), 15,
               'the reset in the log')


# ---------------------------------------------------------------- parameters

def _described() -> dict[str, dict[str, str]]:
    names = [row[0] for row in doc_table('parameters')]
    text = overlay().ask('param', 'describe', NODE, *names).stdout
    out: dict[str, dict[str, str]] = {}
    for block in text.split('Parameter name: ')[1:]:
        lines = block.splitlines()
        fields = {}
        for line in lines[1:]:
            key, _, value = line.strip().partition(': ')
            fields[key] = value
        out[lines[0].strip()] = fields
    return out


def test_param_describe_shows_every_range_and_read_only_of_the_readme(node):
    rows = doc_table('parameters')
    described = _described()
    assert set(described) == {row[0] for row in rows}
    number = r'(-?[\d.]+(?:e[-+]?\d+)?)'
    for name, _symbol, _default, _unit, valid, meaning in rows:
        d = described[name]
        assert (d.get('Read only') == 'true') == meaning.endswith('(read-only)'), name
        if valid in ('–', ''):
            continue
        choices = [c.strip() for c in valid.split('\\|')]
        if len(choices) > 1:
            assert d['Additional constraints'] == 'one of ' + ', '.join(choices), (name, d)
        else:
            assert d['Additional constraints'].startswith(valid), (name, d)
        bounded = re.fullmatch(rf'(0 or )?{number} … {number}', valid)
        if bounded and 'array' not in d['Type']:
            low = 0.0 if bounded.group(1) else float(bounded.group(2))
            assert float(d['Min value']) == pytest.approx(low, rel=1e-5), (name, d)
            assert float(d['Max value']) == pytest.approx(float(bounded.group(3)),
                                                          rel=1e-5), (name, d)


#: (parameter, value as typed, taken?, what the reply says when refused)
SETS = [
    ('mesh_damping', '700.25', True, ''),
    ('mesh_damping', '700', True, ''),                       # an integer for a double
    ('mesh_damping', '2.0e+9', False, 'mesh_damping'),       # over 1e9
    ('mesh_damping', '-1.0', False, 'mesh_damping'),
    ('mesh_damping', 'abc', False, 'Wrong parameter type'),
    ('teeth_table', '1.5', False, 'Wrong parameter type'),
    ('dt', '0.0001', False, 'read-only'),
    ('mode', 'conventional', False, 'read-only'),
    ('radius_pinion_3', '0.09', False, 'must equal radius_pinion_1'),
    ('ste_amplitudes', '[0.02]', False, 'ste_amplitudes'),   # over 0.01 m
    ('ste_phases', '["x"]', False, 'Wrong parameter type'),
]


@pytest.mark.parametrize('name, typed, taken, reason', SETS,
                         ids=[f'{n}={v}' for n, v, *_ in SETS])
def test_param_set_takes_a_valid_value_and_refuses_others_with_the_reason(
        node, name, typed, taken, reason):
    def value():
        return node.peer.get_parameters(NODE, [name])[name]

    before, log_before = value(), len(node.log())
    done = overlay().ask('param', 'set', NODE, name, typed)
    said = done.stdout + done.stderr
    if taken:
        assert 'Set parameter successful' in said, said
        assert value() == float(typed)
    else:
        assert 'Setting parameter failed' in said and reason in said, said
        assert value() == before
    assert node.proc.alive()
    new = node.log()[log_before:]
    assert not any(bad in new for bad in LOG_ERRORS), new


def _read(node: Node, *names: str) -> list:
    """Parameters of the module's node, read by the test's own peer."""
    values = node.peer.get_parameters(NODE, names)
    return [values[name] for name in names]


def test_param_set_of_the_ste_arrays_completes_the_other_with_zeros(node):
    ros2 = overlay()
    assert 'successful' in ros2.ask('param', 'set', NODE, 'ste_amplitudes',
                                    '[1.0e-6, 2.0e-7]').stdout
    assert _read(node, 'ste_amplitudes', 'ste_phases') == [[1.0e-6, 2.0e-7], [0.0, 0.0]]
    assert 'successful' in ros2.ask('param', 'set', NODE, 'ste_phases', '[0.5, 0.25]').stdout
    assert _read(node, 'ste_amplitudes', 'ste_phases') == [[1.0e-6, 2.0e-7], [0.5, 0.25]]
    assert 'ste_phases set to [0.0, 0.0]' in node.log()
    assert not any(bad in node.log() for bad in LOG_ERRORS)


def test_a_shorter_ste_phases_never_silently_drops_an_amplitude(node):
    ros2 = overlay()
    ros2.ask('param', 'set', NODE, 'ste_amplitudes', '[1.0e-6, 2.0e-7]')
    done = ros2.ask('param', 'set', NODE, 'ste_phases', '[0.5]')
    refused = 'Setting parameter failed' in done.stdout + done.stderr
    (amplitudes,) = _read(node, 'ste_amplitudes')
    assert refused or amplitudes == [1.0e-6, 2.0e-7], amplitudes


def _dump(node: str) -> dict:
    return yaml.safe_load(overlay().ask('param', 'dump', node).stdout)


def _bits(tree):
    """Values with floats as their bits, so 0.1 == 0.1 only bit for bit."""
    if isinstance(tree, dict):
        return {k: _bits(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_bits(v) for v in tree]
    if isinstance(tree, float):
        return ('nan',) if math.isnan(tree) else tree.hex()
    return tree


def test_param_dump_then_a_restart_with_it_gives_identical_parameters(tmp_path):
    ros2 = overlay()
    name = '/dumped/table_sim'
    first = ros2.start('run', PACKAGE, 'table_sim', '--ros-args', '-r', '__ns:=/dumped',
                       '-p', 'encoder_counts_table:=4096', '-p', 'preload_torque:=333.3',
                       '-p', 'ste_amplitudes:=[1.0e-6, 3.0e-7]', workdir=tmp_path / 'first')
    second = None
    try:
        assert 'successful' in ros2.ask('param', 'set', name, 'mesh_damping', '0.1').stdout
        dumped = ros2.ask('param', 'dump', name).stdout
        (tmp_path / 'dump.yaml').write_text(dumped)
        assert stop_group(first) == 0
        second = ros2.start('run', PACKAGE, 'table_sim', '--ros-args', '-r', '__ns:=/dumped',
                            '--params-file', str(tmp_path / 'dump.yaml'),
                            workdir=tmp_path / 'second')
        again = _dump(name)
        assert _bits(again) == _bits(yaml.safe_load(dumped))
        assert again[name]['ros__parameters']['encoder_counts_table'] == 4096
        assert stop_group(second) == 0
    finally:
        kill_group(first)
        if second is not None:
            kill_group(second)


def _read_as_text(value) -> bool:
    """Whether rclpy's parameter file loader (``ros2 param load``) sends ``value`` as a
    string: it reads each value back from ``str(value)`` with YAML 1.1, where ``1e-06``
    (no dot) is text. Upstream behaviour of rclpy's ``parameter_dict_from_yaml_file``."""
    values = value if isinstance(value, list) else [value]
    return any(isinstance(v, float) and isinstance(yaml.safe_load(str(v)), str)
               for v in values)


def test_param_load_of_a_dump_sets_what_can_change_and_refuses_read_only(node, tmp_path):
    """docs/parameters.md: physical parameters change at run time, a refused value is named with
    the reason and the simulation keeps running; read-only ones are fixed for a run.
    (A double such as effort_deadband's 1e-06 reaches the node as text through rclpy's
    loader and is refused as the wrong type: see :func:`_read_as_text`.)"""
    ros2 = overlay()
    dump = _dump(NODE)
    values = dump[NODE]['ros__parameters']
    values['mesh_damping'] = 640.25
    values['dt'] = 1.0e-4
    (tmp_path / 'dump.yaml').write_text(yaml.safe_dump(dump))
    log_before = len(node.log())
    done = ros2.ask('param', 'load', NODE, str(tmp_path / 'dump.yaml'))
    replies = {}
    for line in (done.stdout + done.stderr).splitlines():
        said = re.fullmatch(r'Set parameter (\w+) (successful|failed)(?:: (.*))?', line)
        if said:
            replies[said.group(1)] = (said.group(2) == 'successful', said.group(3))
    assert set(replies) == set(values)
    read_only = {row[0] for row in doc_table('parameters')
                 if row[5].endswith('(read-only)')} | {'start_type_description_service'}
    for param, (taken, reason) in replies.items():
        if param in read_only:
            assert not taken and 'read-only' in reason, (param, reason)
        elif _read_as_text(values[param]):
            assert not taken and 'Wrong parameter type' in reason, (param, reason)
        else:
            assert taken, (param, reason)
    assert _read(node, 'mesh_damping', 'dt') == [640.25, PAPER['dt']]
    before = len(node.states.snapshot())
    wait_until(lambda: len(node.states.snapshot()) > before + 10, 15, 'joint_states going on')
    new = node.log()[log_before:]
    assert not any(bad in new for bad in LOG_ERRORS), new
