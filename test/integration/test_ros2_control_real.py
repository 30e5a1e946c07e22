"""table_sim under the real ros2_control stack: ``ros2_control_node`` running the stock
``joint_state_topic_hardware_interface/JointStateTopicSystem``, ``joint_state_broadcaster``
and ``effort_controllers/JointGroupEffortController``, with the shipped URDF and
config/ros2_control.yaml unchanged.

Runs where a built stack is found: ``SCREWGEAR_ROS2_CONTROL_PREFIX``, ``../shared/ros2_control``
beside the checkout, or the default prefix of scripts/ros2_control_stack.sh; skipped with
the reason otherwise.

The processes are those of the installed ``ros2_control.launch.py``: the test reads its
launch description (with a small reader of the launch API it uses, as ``launch`` and
``launch_ros`` have no wheels) and starts each ``Node`` from the ament index as
``launch_ros`` would. Two of them cannot run from a pip install, and the test takes their
part: robot_state_publisher (C++, not built here) is a small stand-in package that
publishes its ``robot_description`` parameter, transient local, where the controller
manager takes the URDF from; the stock ``spawner`` needs ros2cli's ``ros2param``: it runs
(``python -m controller_manager.spawner``, its script names the build's interpreter) from
the tests' overlay of the real ros2 CLI (test/support/ros2cli.py). Where the overlay's
wheels are not found, each spawner's controller is loaded, configured and activated
through the controller manager's services instead, as the spawner does.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import math
import os
import signal
import subprocess
import sys
import time
import types
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from paths import ROOT
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros2cli import (
    overlay,
    ros2cli_overlay,  # noqa: F401  (the fixture that builds the overlay first)
    why_not,
)
from ros_procs import STARTUP_TIMEOUT, Peer, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, Int8

SCRIPT = ROOT / 'scripts' / 'ros2_control_stack.sh'
NODE_EXE = Path('lib/controller_manager/ros2_control_node')
PACKAGE = 'screwgear_ros'
LAUNCH = 'ros2_control.launch.py'
T_P = 350.0                      # default preload torque (config/paper.yaml), N·m
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _default_prefix() -> Path:
    cache = Path(os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache')
    return cache / 'screwgear_ros' / 'ros2_control' / 'install'


def find_prefix() -> tuple[Path | None, str]:
    """The built stack's prefix, or None and why none was taken."""
    chosen = os.environ.get('SCREWGEAR_ROS2_CONTROL_PREFIX')
    if chosen:
        if (Path(chosen) / NODE_EXE).is_file():
            return Path(chosen), ''
        return None, f'SCREWGEAR_ROS2_CONTROL_PREFIX={chosen} holds no {NODE_EXE}'
    for candidate in (ROOT.parent / 'shared' / 'ros2_control', _default_prefix()):
        if (candidate / NODE_EXE).is_file():
            return candidate, ''
    return None, ('no built ros2_control stack (SCREWGEAR_ROS2_CONTROL_PREFIX, '
                  f'../shared/ros2_control, {_default_prefix()}): build one with '
                  'scripts/ros2_control_stack.sh')


PREFIX, WHY_NOT = find_prefix()
pytestmark = [pytest.mark.skipif(PREFIX is None, reason=WHY_NOT),
              pytest.mark.usefixtures('ros2cli_overlay')]


# ---------------------------------------------------------------- reading the launch file

class _Context:
    """What launch's LaunchContext offers the substitutions used here."""

    def __init__(self) -> None:
        self.launch_configurations: dict[str, str] = {}


def perform(value: Any, context: _Context) -> Any:
    """A substitution (or a list of them, or plain text) as launch would resolve it."""
    if isinstance(value, (list, tuple)) and all(isinstance(v, (str, _Substitution))
                                                for v in value):
        return ''.join(perform(v, context) for v in value)
    if isinstance(value, _Substitution):
        return value.perform(context)
    return value


class _Substitution:
    def perform(self, context: _Context) -> str:
        raise NotImplementedError


class LaunchConfiguration(_Substitution):
    def __init__(self, name: str, default: Any = None) -> None:
        self.name, self.default = name, default

    def perform(self, context: _Context) -> str:
        if self.name in context.launch_configurations:
            return context.launch_configurations[self.name]
        if self.default is None:
            raise KeyError(f'launch configuration {self.name!r} is not set')
        return perform(self.default, context)


@dataclass
class NodeSpec:
    """A launch_ros Node, its substitutions resolved."""

    package: str
    executable: str
    name: str | None = None
    namespace: str | None = None
    parameters: list[Any] = field(default_factory=list)
    arguments: list[str] = field(default_factory=list)
    remappings: list[tuple[str, str]] = field(default_factory=list)


class _Action:
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.args, self.kwargs = args, kwargs


class DeclareLaunchArgument(_Action):
    def visit(self, context: _Context) -> list[Any]:
        name = self.args[0]
        default = self.kwargs.get('default_value')
        if name not in context.launch_configurations and default is not None:
            context.launch_configurations[name] = perform(default, context)
        return []


class OpaqueFunction(_Action):
    def visit(self, context: _Context) -> list[Any]:
        function = self.kwargs.get('function') or self.args[0]
        return list(function(context, *self.kwargs.get('args', []),
                             **self.kwargs.get('kwargs', {})) or [])


class PythonLaunchDescriptionSource:
    def __init__(self, path: Any) -> None:
        self.path = path


class IncludeLaunchDescription(_Action):
    def visit(self, context: _Context) -> list[Any]:
        source = self.args[0] if self.args else self.kwargs['launch_description_source']
        for name, value in self.kwargs.get('launch_arguments') or []:
            context.launch_configurations[perform(name, context)] = perform(value, context)
        return [_load(Path(perform(source.path, context)))]


class LaunchDescription:
    def __init__(self, entities: Any = ()) -> None:
        self.entities = list(entities)

    def visit(self, context: _Context) -> list[Any]:
        return self.entities


class ParameterValue:
    def __init__(self, value: Any, value_type: Any = None) -> None:
        self.value, self.value_type = value, value_type


class Node(_Action):
    def visit(self, context: _Context) -> list[Any]:
        kw = self.kwargs

        def resolved(value: Any) -> Any:
            if isinstance(value, dict):
                return {perform(k, context): resolved(v) for k, v in value.items()}
            if isinstance(value, ParameterValue):
                plain = perform(value.value, context)
                return value.value_type(plain) if value.value_type else yaml.safe_load(plain)
            return perform(value, context)
        context.nodes.append(NodeSpec(
            package=kw['package'], executable=kw['executable'],
            name=perform(kw.get('name'), context),
            namespace=perform(kw.get('namespace'), context) or None,
            parameters=[resolved(p) for p in kw.get('parameters') or []],
            arguments=[perform(a, context) for a in kw.get('arguments') or []],
            remappings=[(perform(a, context), perform(b, context))
                        for a, b in kw.get('remappings') or []]))
        return []


class RegisterEventHandler(_Action):
    """The exit watches of the launch files: nothing to start (the fixture checks each
    process's exit itself)."""

    def visit(self, context: _Context) -> list[Any]:
        return []


def _load(path: Path) -> LaunchDescription:
    spec = importlib.util.spec_from_file_location(f'_launch_{path.stem.replace(".", "_")}',
                                                  path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.generate_launch_description()


@contextmanager
def _launch_api():
    """``launch``/``launch_ros`` as the reader above, for the launch file's imports."""
    modules = {
        'launch': {'LaunchDescription': LaunchDescription},
        'launch.actions': {'DeclareLaunchArgument': DeclareLaunchArgument,
                               'IncludeLaunchDescription': IncludeLaunchDescription,
                               'OpaqueFunction': OpaqueFunction,
                               'RegisterEventHandler': RegisterEventHandler},
        'launch.event_handlers': {'OnProcessExit': _Action, 'OnProcessIO': _Action},
        'launch.launch_description_sources': {
            'PythonLaunchDescriptionSource': PythonLaunchDescriptionSource},
        'launch.substitutions': {'LaunchConfiguration': LaunchConfiguration},
        'launch_ros': {},
        'launch_ros.actions': {'Node': Node},
        'launch_ros.parameter_descriptions': {'ParameterValue': ParameterValue},
    }
    saved = {name: sys.modules.get(name) for name in modules}
    for name, attrs in modules.items():
        module = types.ModuleType(name)
        module.__dict__.update(attrs)
        sys.modules[name] = module
    try:
        yield
    finally:
        for name, module in saved.items():
            if module is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = module


def launch_nodes(path: Path, arguments: dict[str, str]) -> list[NodeSpec]:
    """The Nodes the launch file at ``path`` starts, in order, given launch
    ``arguments`` (as ``ros2 launch ... name:=value``; the rest at their defaults)."""
    context = _Context()
    context.launch_configurations.update(arguments)
    context.nodes = []
    with _launch_api():
        todo = [_load(path)]
        while todo:
            todo[:0] = todo.pop(0).visit(context)   # depth first, in order, as launch
    return context.nodes


# ---------------------------------------------------------------- the processes

def runtime_env(stand_ins: Path) -> dict[str, str]:
    """The environment ros2_control_node needs, from the build script's --print-env, with
    the stand-in packages on the ament index."""
    shell = (f'eval "$(bash {SCRIPT} --print-env --prefix {PREFIX})" && '
             f'AMENT_PREFIX_PATH="$AMENT_PREFIX_PATH:{stand_ins}" && env -0')
    out = subprocess.run(['bash', '-c', shell], check=True, capture_output=True,
                         env={**os.environ, 'SCREWGEAR_VENV': sys.prefix}).stdout
    return dict(item.split('=', 1) for item in out.decode().split('\0') if '=' in item)


STAND_IN_RSP = '''\
"""robot_state_publisher's part here: its robot_description parameter, published
transient local on robot_description. No /tf: nothing in the test reads it."""
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

rclpy.init()
node = rclpy.create_node('robot_state_publisher')
text = node.declare_parameter('robot_description', '').value
pub = node.create_publisher(String, 'robot_description', QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL))
pub.publish(String(data=text))
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
'''


def stand_in_packages(root: Path, package_xml: str) -> Path:
    """An ament prefix with robot_state_publisher's stand-in, at the version this
    package's package.xml asks for (if any)."""
    minimum = {e.text.strip(): e.get('version_gte') for e in ET.fromstring(package_xml)
               .iter('exec_depend') if e.text}.get('robot_state_publisher') or '0.0.0'
    name = 'robot_state_publisher'
    (root / 'share/ament_index/resource_index/packages').mkdir(parents=True)
    (root / 'share/ament_index/resource_index/packages' / name).touch()
    (root / 'share' / name).mkdir(parents=True)
    (root / 'share' / name / 'package.xml').write_text(
        f'<package format="3"><name>{name}</name><version>{minimum}</version></package>')
    exe = root / 'lib' / name / name
    exe.parent.mkdir(parents=True)
    exe.write_text(f'#!{sys.executable}\n{STAND_IN_RSP}')
    exe.chmod(0o755)
    return root


def executable(env: dict[str, str], package: str, exe: str) -> Path:
    for prefix in env['AMENT_PREFIX_PATH'].split(os.pathsep):
        path = Path(prefix) / 'lib' / package / exe
        if path.is_file() and os.access(path, os.X_OK):
            return path
    raise AssertionError(f'{package}/{exe} is on no prefix of AMENT_PREFIX_PATH')


@dataclass
class Proc:
    spec: NodeSpec
    popen: subprocess.Popen
    log: Path

    def output(self) -> str:
        return self.log.read_text(errors='replace')


def start(spec: NodeSpec, env: dict[str, str], workdir: Path) -> Proc:
    """The process launch_ros would start for ``spec``, in its own process group; the
    spawner with the overlay's interpreter, on the overlay's paths."""
    path = executable(env, spec.package, spec.executable)
    command = [str(path)]
    if spec.executable == 'spawner':
        command = [str(overlay().python), '-m', f'{spec.package}.{spec.executable}']
        env = overlay().env(base=env)
    args = [*command, *spec.arguments, '--ros-args']
    if spec.name:
        args += ['-r', f'__node:={spec.name}']
    if spec.namespace:
        args += ['-r', f'__ns:=/{spec.namespace.strip("/")}']
    for k, p in enumerate(spec.parameters):
        if isinstance(p, dict):
            path = workdir / f'{spec.executable}_{k}.yaml'
            path.write_text(yaml.safe_dump({'/**': {'ros__parameters': p}}))
            p = path
        args += ['--params-file', str(p)]
    for a, b in spec.remappings:
        args += ['-r', f'{a}:={b}']
    log = workdir / f'{spec.executable}_{len(list(workdir.glob("*.log")))}.log'
    with open(log, 'w') as out:
        popen = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, cwd=workdir,
                                 env={**env, 'PYTHONUNBUFFERED': '1',
                                      'RCUTILS_COLORIZED_OUTPUT': '0'},
                                 start_new_session=True)
    return Proc(spec, popen, log)


#: The spawner's service calls: load, configure, then activate (strict) or deactivate.
SERVICE_SPAWNER = '''\
import json, sys
import rclpy
from builtin_interfaces.msg import Duration
from controller_manager_msgs.srv import (ConfigureController, LoadController,
                                         SwitchController)
mode, manager, names = sys.argv[1], sys.argv[2].rstrip('/'), sys.argv[3:]
rclpy.init()
node = rclpy.create_node('screwgear_test_spawner')


def call(kind, service, request):
    client = node.create_client(kind, f'{manager}/{service}')
    if not client.wait_for_service(timeout_sec=30.0):
        raise SystemExit(f'{manager}/{service} is not there')
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future, timeout_sec=30.0)
    return future.result()


result = {}
switch = SwitchController.Request(strictness=SwitchController.Request.STRICT,
                                  timeout=Duration(sec=10))
if mode == 'activate':
    for name in names:
        result[f'load {name}'] = call(LoadController, 'load_controller',
                                      LoadController.Request(name=name)).ok
        result[f'configure {name}'] = call(ConfigureController, 'configure_controller',
                                           ConfigureController.Request(name=name)).ok
    switch.activate_controllers = names
else:
    switch.deactivate_controllers = names
result[f'{mode} {" ".join(names)}'] = call(SwitchController, 'switch_controller', switch).ok
print(json.dumps(result))
'''


def spawn(env: dict[str, str], mode: str, manager: str, names: list[str]) -> dict[str, bool]:
    """What the stock spawner does for ``names``, through the manager's services."""
    done = subprocess.run([sys.executable, '-c', SERVICE_SPAWNER, mode, manager, *names],
                          env=env, capture_output=True, text=True, timeout=90, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def spawner_args(spec: NodeSpec) -> tuple[str, list[str]]:
    """(controller manager, controllers) of a spawner's command line."""
    args, manager, names = list(spec.arguments), '/controller_manager', []
    while args:
        a = args.pop(0)
        if a in ('--controller-manager', '-c'):
            manager = args.pop(0)
        elif a.startswith('-'):
            raise AssertionError(f'spawner option {a} is unknown to the test')
        else:
            names.append(a)
    return manager, names


def stop_all(procs: list[Proc]) -> dict[str, int]:
    """SIGINT each process group in turn, the controller manager first (then nothing
    writes joint_commands any more), table_sim last; SIGKILL what is left after 10 s.
    Each group is waited for before the next is signalled, so no stop overlaps another."""
    order = sorted(procs, key=lambda p: (p.spec.executable != 'ros2_control_node',
                                         p.spec.package == PACKAGE))
    codes = {}
    for p in order:
        if p.popen.poll() is None:
            os.killpg(p.popen.pid, signal.SIGINT)
            with contextlib.suppress(subprocess.TimeoutExpired):
                p.popen.wait(timeout=10.0)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(p.popen.pid, signal.SIGKILL)       # a child it left behind
        p.popen.wait()
        codes[p.spec.executable] = p.popen.returncode
    return codes


def group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


# ---------------------------------------------------------------- the fixture

def hardware(urdf: str) -> tuple[list[str], dict[str, int], dict[str, str]]:
    """(joints in order, number of command interfaces of each kind, hardware params) of
    the URDF's ros2_control block: the layout of the plugin's messages."""
    block = ET.fromstring(urdf).find('ros2_control')
    joints = [j.get('name') for j in block.iterfind('joint')]
    kinds = {kind: len(block.findall(f'joint/command_interface[@name="{kind}"]'))
             for kind in ('position', 'velocity', 'effort')}
    params = {p.get('name'): (p.text or '').strip() for p in block.iterfind('hardware/param')}
    return joints, kinds, params


@dataclass
class Stack:
    peer: Peer
    env: dict[str, str]
    procs: list[Proc]
    nodes: list[NodeSpec]
    spawners: list[tuple[str, list[str]]]
    joints: list[str]
    kinds: dict[str, int]
    commands: Any            # Inbox of the plugin's messages
    node_js: Any
    broadcast: Any
    path: Any
    diag: Any
    effort_pub: Any = None
    activated: dict[str, bool] = field(default_factory=dict)
    bag: Path | None = None
    topic_states: str = ''

    def proc(self, executable: str) -> Proc:
        return next(p for p in self.procs if p.spec.executable == executable)

    def command(self, value: float, echoed: bool = True, timeout: float = 30.0) -> None:
        """Publish ``value`` to the effort controller until the plugin sends it on (as
        ``ros2 topic pub -r`` does: a message sent just after the match may not arrive)."""
        deadline = time.monotonic() + timeout
        while True:
            self.effort_pub.publish(Float64MultiArray(data=[value]))
            if not echoed:
                return
            try:
                self.commands.wait_next(lambda m: m.effort[0] == value, 0.25)
                return
            except AssertionError:
                if time.monotonic() > deadline:
                    raise AssertionError(
                        f'the plugin did not send {value} within {timeout} s') from None


@pytest.fixture(scope='module')
def stack(tmp_path_factory):
    from ament_index_python.packages import get_package_share_directory
    share = Path(get_package_share_directory(PACKAGE))
    work = tmp_path_factory.mktemp('ros2_control_real')
    stand_ins = stand_in_packages(work / 'stand_ins', (share / 'package.xml').read_text())
    env = runtime_env(stand_ins)
    saved_prefix = os.environ.get('AMENT_PREFIX_PATH')
    os.environ['AMENT_PREFIX_PATH'] = env['AMENT_PREFIX_PATH']   # for the launch file's checks
    try:
        nodes = launch_nodes(share / 'launch' / LAUNCH, {'record': str(work / 'run')})
    finally:
        if saved_prefix is None:
            os.environ.pop('AMENT_PREFIX_PATH', None)
        else:
            os.environ['AMENT_PREFIX_PATH'] = saved_prefix
    runs_spawner = overlay() is not None
    urdf = (share / 'urdf' / 'screwgear_table.urdf').read_text()
    joints, kinds, params = hardware(urdf)
    peer = Peer('test_ros2_control_real')
    procs: list[Proc] = []
    try:
        st = Stack(peer, env, procs, nodes, [], joints, kinds,
                   commands=peer.subscribe(params['joint_commands_topic'], JointState),
                   node_js=peer.subscribe(params['joint_states_topic'], JointState),
                   broadcast=peer.subscribe('/joint_states', JointState),
                   path=None, diag=peer.subscribe('/diagnostics', DiagnosticArray))
        st.bag, st.topic_states = work / 'run', params['joint_states_topic']
        namespace = params['joint_states_topic'].rpartition('/')[0]
        st.path = peer.subscribe(f'{namespace}/active_path', Int8, LATCHED)
        stock_spawners = []
        for spec in nodes:
            if spec.executable == 'spawner':
                if runs_spawner:
                    stock_spawners.append(spec)
                else:
                    st.spawners.append(spawner_args(spec))
                continue
            procs.append(start(spec, env, work))
            if spec.package == PACKAGE:
                st.node_js.wait_for(lambda m: True, STARTUP_TIMEOUT, "table_sim's joint_states")
        # the controllers once the hardware has the node's states (the broadcaster of a
        # controller activated before would publish the interfaces' initial NaNs)
        st.commands.wait_for(lambda m: True, STARTUP_TIMEOUT, "the plugin's first message")
        # all at once, as launch starts the spawners
        spawned = [start(spec, env, work) for spec in stock_spawners]
        procs.extend(spawned)
        for p in spawned:
            assert p.popen.wait(timeout=90) == 0, p.output()[-3000:]
        with ThreadPoolExecutor() as pool:
            for done in pool.map(lambda s: spawn(env, 'activate', *s), st.spawners):
                st.activated.update(done)
        st.effort_pub = peer.publisher('/effort_controller/commands', Float64MultiArray)
        yield st
    finally:
        stop_all(procs)
        peer.close()


# ---------------------------------------------------------------- the tests

@pytest.mark.ros
def test_the_launch_files_processes_run_and_its_controllers_are_active(stack):
    executables = [(n.package, n.executable) for n in stack.nodes]
    assert (PACKAGE, 'table_sim') in executables
    assert ('controller_manager', 'ros2_control_node') in executables
    config = yaml.safe_load(Path(stack.proc('ros2_control_node').spec.parameters[0])
                             .read_text())
    declared = [k for k, v in config['controller_manager']['ros__parameters'].items()
                if isinstance(v, dict) and 'type' in v]
    spawned = [name for n in stack.nodes if n.executable == 'spawner'
               for name in spawner_args(n)[1]]
    assert sorted(spawned) == sorted(declared)
    if stack.spawners:                      # each spawner's calls, each answered ok
        assert stack.activated == {
            **{f'{step} {name}': True for _, names in stack.spawners for name in names
               for step in ('load', 'configure')},
            **{f'activate {" ".join(names)}': True for _, names in stack.spawners}}
    for p in stack.procs:
        if p.spec.executable != 'spawner':
            assert p.popen.poll() is None, f'{p.spec.executable} ended:\n{p.output()[-3000:]}'


@pytest.mark.ros
def test_the_plugins_messages_have_the_readmes_layout_nan_first(stack):
    msgs = stack.commands.snapshot()
    assert msgs
    for m in msgs:
        assert list(m.name) == stack.joints
        assert len(m.position) == stack.kinds['position'] == 0
        assert len(m.velocity) == stack.kinds['velocity'] == 0
        assert len(m.effort) == stack.kinds['effort'] == 1
        assert math.isnan(m.effort[0])             # no command yet
    assert stack.node_js.latest().effort[0] == T_P   # no drive
    # the controller manager's cycle as the plugin's stamps show it (a figure, not a test)
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in msgs]
    if len(stamps) > 1:
        print(f'\nplugin: {len(stamps)} messages at {(len(stamps) - 1) / (stamps[-1] - stamps[0]):.0f} Hz')


@pytest.mark.ros
def test_twenty_newton_metres_forward_then_back_turn_the_table_and_switch_the_path(stack):
    js = stack.node_js
    assert stack.path.wait_for(lambda m: True, 10, 'active_path').data == 1
    stack.command(20.0)
    m = js.wait_next(lambda m: m.effort[0] == T_P + 20.0, 10, 'the forward drive')
    assert m.effort[2] == -T_P
    start = js.latest().position[1]
    js.wait_next(lambda m: m.velocity[1] > 0.0 and m.position[1] > start + 0.01, 15,
                 'the table turning forward')
    stack.command(-20.0)
    stack.path.wait_for(lambda m: m is stack.path.latest() and m.data == 3, 10,
                        'active_path 3')
    m = js.wait_next(lambda m: m.effort[2] == -T_P - 20.0, 10, 'the drive on path 3')
    assert m.effort[0] == T_P
    turned = js.wait_next(lambda m: m.velocity[1] < 0.0, 15, 'the table turning back')
    js.wait_next(lambda m: m.position[1] < turned.position[1] - 0.01, 15,
                 'the table going back')


@pytest.mark.ros
def test_the_node_took_every_plugin_message_without_a_warning(stack):
    diag = stack.diag.wait_next(lambda m: any(kv.key == 'rejected_joint_commands'
                                              for s in m.status for kv in s.values),
                                15, 'diagnostics')
    values = {kv.key: kv.value for s in diag.status for kv in s.values}
    assert values['rejected_joint_commands'] == '0'
    log = stack.proc('table_sim').output()
    assert 'joint_commands' not in log.replace('cmd_effort, joint_commands or ~/tick', ''), log
    assert 'WARN' not in log, log


def rejected(stack) -> int:
    diag = stack.diag.wait_next(lambda m: any(kv.key == 'rejected_joint_commands'
                                              for s in m.status for kv in s.values),
                                15, 'diagnostics')
    return int({kv.key: kv.value for s in diag.status for kv in s.values}[
        'rejected_joint_commands'])


@pytest.mark.ros
def test_over_the_urdf_limit_a_command_passes_the_manager_and_the_node_refuses_it(stack):
    """Jazzy's controller manager leaves the URDF's command limits alone unless
    ``enforce_command_limits`` is set (config/ros2_control.yaml does not): 500 N·m
    reaches the node, which refuses it as over max_torque, counts it and keeps the
    drive in force."""
    assert 'Enforcing command limits is disabled' in stack.proc('ros2_control_node').output()
    before = rejected(stack)
    stack.command(500.0)
    wait_until(lambda: rejected(stack) > before, 15, 'the node counting the refusal')
    # The drive in force (−20 N·m, path 3) stays: pinion 1 carries the preload alone and
    # pinion 3 at most 20 N·m of drive beyond it. The drive line delivers less as the
    # pinion speeds up, and brakes past its no-load speed, so the effort itself moves
    # from sample to sample; 500 N·m applied would have put pinion 3 far below.
    effort = stack.node_js.wait_next(lambda m: True, 10).effort
    assert effort[0] == T_P and effort[2] >= -T_P - 20.0, effort
    assert 'joint_commands: rejected' in stack.proc('table_sim').output()
    stack.command(-20.0)


@pytest.mark.ros
def test_deactivating_the_controller_leaves_zero_drive_and_the_direction(stack):
    """JointGroupEffortController writes 0.0 on deactivation; the plugin keeps sending
    it: no drive, the direction kept. Deactivated as it was activated: by the stock
    unspawner where the stock spawner ran, else through the manager's services."""
    if stack.spawners:
        manager = stack.spawners[0][0]
        assert spawn(stack.env, 'deactivate', manager, ['effort_controller']) == {
            'deactivate effort_controller': True}
    else:
        manager = next(spawner_args(n)[0] for n in stack.nodes if n.executable == 'spawner')
        done = subprocess.run([str(overlay().python), '-m', 'controller_manager.unspawner',
                               'effort_controller', '--controller-manager', manager],
                              env=overlay().env(base=stack.env), capture_output=True,
                              text=True, timeout=90, check=False)
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    stack.commands.wait_next(lambda m: m.effort[0] == 0.0, 10, 'the plugin sending 0.0')
    stack.node_js.wait_next(lambda m: m.effort[0] == T_P and m.effort[2] == -T_P, 10,
                            'no drive')
    assert stack.path.latest().data == 3
    stack.command(30.0, echoed=False)            # nobody listens: the 0.0 stays
    time.sleep(0.5)
    assert all(m.effort[0] == 0.0 for m in stack.commands.snapshot()[-100:])


@pytest.mark.ros
@pytest.mark.skipif(bool(why_not()), reason=why_not() or 'overlay found')
def test_ros2_launch_refuses_a_missing_params_file_before_it_starts_anything(stack,
                                                                            tmp_path):
    """With every package it needs on the paths, the real ``ros2 launch`` gets past the
    package check and ends on the parameter file, non-zero, nothing started."""
    missing = tmp_path / 'no_such.yaml'
    done = subprocess.run([str(overlay().ros2), 'launch', PACKAGE, LAUNCH, 'namespace:=axis_x',
                           f'params_file:={missing}'], env=overlay().env(base=stack.env),
                          capture_output=True, text=True, timeout=120, check=False)
    output = done.stdout + done.stderr
    assert done.returncode != 0, output
    assert f'params_file {missing} is not a file; nothing was started' in output, output
    assert 'process started' not in output and 'not found' not in output, output


@pytest.mark.ros
def test_no_process_outlives_the_stack(stack):
    """Runs last: stops everything in order and checks each group is gone."""
    procs = list(stack.procs)
    codes = stop_all(procs)
    stack.procs.clear()
    assert codes.get('table_sim') == 0, codes
    for p in procs:
        assert not group_alive(p.popen.pid), f'{p.spec.executable} left a process behind'


def values(m: Any) -> dict[tuple[str, str], float]:
    """A JointState's values by (joint, field)."""
    return {(name, kind): value for kind in ('position', 'velocity', 'effort')
            for name, value in zip(m.name, getattr(m, kind), strict=False)}


#: How many samples apart the two that a broadcaster message mixes may be: the plugin's
#: best-effort subscription skips some when the controller manager's loop falls behind.
MIX_SPAN = 20


@pytest.mark.ros
def test_the_broadcasters_joint_states_mirror_the_nodes(stack):
    """Runs after the stop: every broadcaster message the test got holds, joint by joint,
    the values of the node's joint_states as its recording (read with rosbags, which
    loses none) has them: the plugin copies the last message it got, the broadcaster
    publishes it. The plugin's subscription callback overwrites that copy while the
    control loop reads it, with no lock: now and then a message mixes two samples the
    plugin received one after the other (best effort: not always consecutive ones),
    value by value; nothing else is accepted."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore
    assert not stack.procs, 'runs after test_no_process_outlives_the_stack'
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(stack.bag) as reader:
        connections = [c for c in reader.connections if c.topic == stack.topic_states]
        recorded = [values(store.deserialize_cdr(raw, c.msgtype))
                    for c, _, raw in reader.messages(connections=connections)]
    where: dict[tuple, list[int]] = {}
    for k, sample in enumerate(recorded):
        for key, value in sample.items():
            where.setdefault((key, value), []).append(k)
    mirrored = stack.broadcast.snapshot()
    assert len(mirrored) > 100 and len(recorded) > 100
    exact = torn = 0
    for m in mirrored:
        assert sorted(m.name) == sorted(stack.joints)
        got = values(m)
        # the samples holding its rarest value, and the ones after them (a mixed
        # message's rarest value may come from the earlier of the two)
        rarest = min((where.get(item, []) for item in got.items()), key=len)
        if any(got == recorded[k] for k in rarest):
            exact += 1
        elif any(all(v in (recorded[j][key], recorded[k][key]) for key, v in got.items())
                 for j in rarest
                 for k in range(max(j - MIX_SPAN, 0), min(j + MIX_SPAN + 1, len(recorded)))):
            torn += 1
        else:
            raise AssertionError(f'{m} is no joint_states sample of the node')
    assert exact > 0.9 * len(mirrored), (exact, torn)
    assert len({tuple(sorted(values(m).items())) for m in mirrored}) > 100   # they moved
    print(f'\nbroadcaster: {exact} exact copies, {torn} mixing two samples')
