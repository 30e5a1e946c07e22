"""The README's "Controller quick start" says what the code does.

Its numbers are recomputed from the parameter declarations (TableParams, SimSettings
defaults), its sign convention is measured on the node's own loop, its QoS list is the
node's declared set of latched outputs, and its controller, extracted exactly as
printed, runs as a process against a real table_sim process (lockstep, paced at real
time) and brings the table to the target it sets. The only wall-clock limits are
generous timeouts.
"""

from __future__ import annotations

import ast
import re
import signal
import subprocess
import sys

import pytest
from paths import ROOT
from ros_procs import STARTUP_TIMEOUT, Peer, assert_clean_exit, stamp_ns, start_process
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from screwgear_ros import Simulation
from screwgear_ros.interface import BY_KEY, LATCHED_OUTPUTS
from screwgear_ros.params.table import SimSettings, TableParams

README = ROOT / 'README.md'
HEADING = '## Controller quick start'
RUN_TIMEOUT = 120.0     # s of wall time for a couple of s of simulation, under load
SETTLED = 2.0           # s of simulation time after which the PD law has settled


def section() -> str:
    text = README.read_text(encoding='utf-8')
    start = text.index(HEADING)
    end = text.find('\n## ', start + len(HEADING))
    return text[start:end if end >= 0 else len(text)]


def controller_code() -> str:
    """The first python block of the section, exactly as printed."""
    match = re.search(r'```python\n(.*?)```', section(), re.DOTALL)
    assert match, 'the quick start has no python block'
    return match.group(1)


def constant(code: str, name: str) -> float:
    """The value the code assigns to ``name`` (plain or in a tuple assignment)."""
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.Assign):
            for target in node.targets:
                names = target.elts if isinstance(target, ast.Tuple) else [target]
                values = node.value.elts if isinstance(node.value, ast.Tuple) else [node.value]
                for n, v in zip(names, values, strict=True):
                    if isinstance(n, ast.Name) and n.id == name:
                        return float(ast.literal_eval(v))
    raise AssertionError(f'the controller sets no {name}')


def test_quick_start_comes_first():
    text = README.read_text(encoding='utf-8')
    first = text.index('\n## ')
    assert text[first + 1:].startswith(HEADING)
    assert text.index(HEADING) < text.index('## The two commands')


def words(text: str) -> str:
    """The text with its line breaks and runs of spaces as single spaces."""
    return ' '.join(text.split())


def test_quick_start_numbers_are_the_codes():
    p, s, text = TableParams(), SimSettings(), words(section())
    ratio = p.radius_table / p.radius_pinion_1
    inertia = p.inertia_table + (p.inertia_pinion_1 + p.inertia_pinion_3) * ratio ** 2
    for phrase in (f'r2/r1 = {ratio:.2f}', f'not the {p.teeth_table / p.teeth_pinion_1:g}',
                   f'J = I2 + (I1 + I3)(r2/r1)² = {inertia:.1f} kg·m²',
                   f'`command_timeout` ({s.command_timeout:g} s',
                   f'`max_torque` ({p.max_torque:g})', f'({s.publish_rate:g} Hz)'):
        assert phrase in text, f'the quick start does not say {phrase!r}'


def test_quick_start_sign_is_measured():
    """A positive effort for 50 ms: the README names the sign θ2 takes."""
    sim = Simulation.from_yaml(ROOT / 'config' / 'paper.yaml')
    sim.reset()
    for _ in range(50):
        observation = sim.step(50.0)
    angle = observation.position[1]
    assert angle != 0.0
    word = 'positive' if angle > 0.0 else 'negative'
    assert f'A positive effort drives θ2 {word}' in words(section())


def test_quick_start_qos_names_the_latched_topics():
    line = next(part for part in section().split('\n- ') if part.startswith('**QoS**'))
    latched = set(re.findall(r'`([^`]+)`', line.split('except', 1)[1]))
    assert latched == {BY_KEY[key].name for key in LATCHED_OUTPUTS}
    assert 'transient local' in words(line)


def test_quick_start_runs_the_node_in_lockstep_and_answers_each_new_stamp_once():
    """The flag, and the lines of the controller that skip a stamp already answered."""
    text, code = words(section()), controller_code()
    assert '-p lockstep:=true' in text, 'the quick start does not start the node in lockstep'
    assert 'msg.header.stamp' in code and 'self.last' in code, (
        'the quick start controller does not remember the stamp it answered')
    assert 'get_subscription_count' in code, (
        'the quick start controller answers before the node can hear it')


@pytest.mark.ros
def test_quick_start_controller_runs_as_printed(tmp_path):
    code = controller_code()
    assert len(code.splitlines()) <= 25, 'the quick start controller is over 25 lines'
    target = constant(code, 'TARGET')
    script = tmp_path / 'my_pd.py'
    script.write_text(code, encoding='utf-8')
    sim = start_process('table_sim', params_file=ROOT / 'config' / 'paper.yaml',
                        params={'lockstep': True, 'real_time_factor': 1.0},
                        workdir=tmp_path / 'sim')
    ctl = None
    try:
        with Peer('test_quickstart') as peer:
            clock = peer.subscribe('/clock', Clock, qos=10, transform=stamp_ns)
            table = peer.subscribe('/joint_states', JointState, qos=10,
                                   transform=lambda m: (stamp_ns(m), m.position[1]))
            ctl = subprocess.Popen([sys.executable, str(script)], cwd=tmp_path,
                                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            clock.wait_for(lambda ns: ns >= SETTLED * 1e9, STARTUP_TIMEOUT + RUN_TIMEOUT,
                           f'{SETTLED} s of simulation time on /clock')
            table.wait_next(timeout=10.0)
        assert ctl.poll() is None, f'the controller exited: {ctl.communicate()[0]}'
        seen = [angle for ns, angle in table.snapshot() if ns >= SETTLED * 1e9]
        assert seen, 'no joint_states after the settling time'
        assert abs(seen[-1] - target) < 0.1 * abs(target), (
            f'table at {seen[-1]:.5f} rad, the controller\'s target {target} rad')
        assert_clean_exit(sim, signal.SIGINT)
    finally:
        sim.kill()
        if ctl is not None:
            ctl.kill()
            ctl.communicate(timeout=10)
