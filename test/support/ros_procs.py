"""Test helpers for real ROS 2 processes: start an installed console script, talk to
it over DDS from the test process, stop it and check it ended cleanly.

* :func:`start_process` runs an executable (``table_sim``, ``replay_run``, ...) with
  ``--ros-args``, parameters from a dict and/or a parameter file, output to files.
* :class:`Peer` is the test's own rclpy node, in its own context, spun on a
  background thread: subscribe into an :class:`Inbox`, publish, call services, set
  and get parameters. Always ``close()`` it (or use it as a context manager).

The environment comes from the test run (conftest.py sets ROS_DOMAIN_ID and keeps
DDS on loopback); children inherit it.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self

import yaml

STARTUP_TIMEOUT = 60.0   # s: the first start of a fresh install compiles the numba core


def write_params_file(path: str | os.PathLike, params: Mapping[str, Any],
                      node: str = '/**') -> Path:
    """Write a ROS 2 parameter file ``{node: {ros__parameters: params}}``.

    Floats stay floats (``1.0``), so double parameters keep their type.
    """
    path = Path(path)
    plain = {k: (list(v) if isinstance(v, tuple) else v) for k, v in params.items()}
    path.write_text(yaml.safe_dump({node: {'ros__parameters': plain}}, sort_keys=False))
    return path


@dataclass
class RosProcess:
    """A started process; its stdout/stderr go to files in ``workdir``."""

    popen: subprocess.Popen
    workdir: Path
    command: list[str]
    _files: list[Any] = field(default_factory=list)

    @property
    def pid(self) -> int:
        return self.popen.pid

    def alive(self) -> bool:
        return self.popen.poll() is None

    def output(self) -> tuple[str, str]:
        """(stdout, stderr) so far."""
        return ((self.workdir / 'stdout.txt').read_text(errors='replace'),
                (self.workdir / 'stderr.txt').read_text(errors='replace'))

    def stop(self, sig: int = signal.SIGINT, timeout: float = 10.0) -> tuple[int, float]:
        """Send ``sig``, wait for the exit; (return code, seconds it took).

        A process still running after ``timeout`` is killed and AssertionError raised.
        """
        if not self.alive():
            self._close_files()
            return self.popen.returncode, 0.0
        t0 = time.monotonic()
        self.popen.send_signal(sig)
        try:
            code = self.popen.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.popen.kill()
            self.popen.wait()
            self._close_files()
            raise AssertionError(f'{self.command[0]} ignored signal {sig} for {timeout} s; '
                                 'killed') from None
        self._close_files()
        return code, time.monotonic() - t0

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        """Teardown: Ctrl-C (the node closes its bag) if still running, SIGKILL last."""
        if self.alive():
            self.stop(signal.SIGINT)
        self.kill()

    def kill(self) -> None:
        """SIGKILL if still running (teardown of last resort)."""
        if self.alive():
            self.popen.kill()
            self.popen.wait()
        self._close_files()

    def _close_files(self) -> None:
        for f in self._files:
            f.close()
        self._files.clear()


def start_process(exe: str, ros_args: Sequence[str] = (),
                  params: Mapping[str, Any] | None = None,
                  params_file: str | os.PathLike | None = None,
                  args: Sequence[str] = (), env: Mapping[str, str] | None = None,
                  workdir: str | os.PathLike | None = None) -> RosProcess:
    """Start console script ``exe`` (looked up on PATH) as a child process.

    Command line: ``exe *args --ros-args *ros_args [--params-file params_file]
    [--params-file <params written to a file>]`` (a later file wins over an earlier
    one). ``env`` adds to the inherited environment.
    """
    workdir = Path(workdir) if workdir is not None else Path(tempfile.mkdtemp(prefix=f'{exe}_'))
    workdir.mkdir(parents=True, exist_ok=True)
    path = shutil.which(exe)
    if path is None:
        raise FileNotFoundError(f'{exe} is not on PATH (is the venv active?)')
    command = [path, *args, '--ros-args', *ros_args]
    if params_file is not None:
        command += ['--params-file', str(params_file)]
    if params:
        command += ['--params-file', str(write_params_file(workdir / 'params.yaml', params))]
    child_env = {**os.environ, 'PYTHONUNBUFFERED': '1', 'RCUTILS_COLORIZED_OUTPUT': '0',
                 **(env or {})}
    out = open(workdir / 'stdout.txt', 'w')  # noqa: SIM115 - the process's, closed with it
    err = open(workdir / 'stderr.txt', 'w')  # noqa: SIM115 - the process's, closed with it
    popen = subprocess.Popen(command, stdout=out, stderr=err, env=child_env, cwd=workdir)
    return RosProcess(popen, workdir, command, [out, err])


def assert_clean_exit(proc: RosProcess, sig: int = signal.SIGINT,
                      timeout: float = 10.0) -> float:
    """Stop ``proc`` with ``sig``; assert exit code 0 and no traceback; return seconds."""
    code, seconds = proc.stop(sig, timeout)
    _, stderr = proc.output()
    assert code == 0, f'exit code {code} after signal {sig}; stderr:\n{stderr[-3000:]}'
    for bad in ('Traceback', 'context is invalid', 'Segmentation fault'):
        assert bad not in stderr, f'{bad!r} in stderr:\n{stderr[-3000:]}'
    return seconds


class Inbox:
    """Messages received on one subscription, thread-safe."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self.messages: list[Any] = []

    def put(self, msg: Any) -> None:
        with self._cond:
            self.messages.append(msg)
            self._cond.notify_all()

    def snapshot(self) -> list[Any]:
        with self._cond:
            return list(self.messages)

    def clear(self) -> None:
        with self._cond:
            self.messages.clear()

    def latest(self) -> Any:
        with self._cond:
            return self.messages[-1] if self.messages else None

    def wait_for(self, predicate: Callable[[Any], bool], timeout: float = 10.0,
                 what: str = 'a matching message') -> Any:
        """The first message (received before or after the call) that satisfies
        ``predicate``; AssertionError after ``timeout`` s."""
        with self._cond:
            return self._wait(0, predicate, timeout, what)

    def wait_next(self, predicate: Callable[[Any], bool] = lambda m: True,
                  timeout: float = 10.0, what: str = 'a new matching message') -> Any:
        """Like :meth:`wait_for`, but only messages received after the call count."""
        with self._cond:
            return self._wait(len(self.messages), predicate, timeout, what)

    def _wait(self, seen: int, predicate: Callable[[Any], bool], timeout: float,
              what: str) -> Any:
        """Scan messages from index ``seen`` on as they arrive; the lock is held."""
        deadline = time.monotonic() + timeout
        while True:
            for msg in self.messages[seen:]:
                if predicate(msg):
                    return msg
            seen = len(self.messages)
            left = deadline - time.monotonic()
            if left <= 0.0:
                raise AssertionError(f'no {what} within {timeout} s '
                                     f'({len(self.messages)} messages received)')
            self._cond.wait(left)


class Peer:
    """The test's own rclpy node in a private context, spun on a background thread."""

    def __init__(self, name: str = 'test_peer', namespace: str = '') -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        from screwgear_ros.ros.shutdown import spin_executor_until

        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(name, namespace=namespace or None, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        # close() stops this loop before it shuts the executor down (shutting it down
        # under a spin raised "'NoneType' object has no attribute 'trigger'" on a busy
        # machine)
        self._thread = threading.Thread(target=spin_executor_until,
                                        args=(self.executor, self._stop, 0.05), daemon=True,
                                        name=f'{name} spin')
        self._thread.start()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop spinning, then the executor, the node and the context, in that order."""
        import rclpy
        self._stop.set()
        self._thread.join(timeout=30.0)     # no thread inside rcl once the node goes
        if self._thread.is_alive():
            raise RuntimeError(f'{self._thread.name}: a callback did not return within 30 s')
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    # topics ------------------------------------------------------------------

    def subscribe(self, topic: str, msg_type: type, qos: Any = 100,
                  transform: Callable[[Any], Any] | None = None) -> Inbox:
        """An Inbox collecting every message on ``topic`` (optionally transformed)."""
        inbox = Inbox()
        put = inbox.put if transform is None else (lambda m: inbox.put(transform(m)))
        self.node.create_subscription(msg_type, topic, put, qos)
        return inbox

    def publisher(self, topic: str, msg_type: type, qos: Any = 10,
                  wait_matched: float | None = 10.0) -> Any:
        """A publisher; by default waits until a subscriber has matched it."""
        pub = self.node.create_publisher(msg_type, topic, qos)
        if wait_matched:
            wait_until(lambda: pub.get_subscription_count() > 0, wait_matched,
                       f'a subscriber on {pub.topic_name}')
        return pub

    # services and parameters --------------------------------------------------

    def call(self, srv_type: type, name: str, request: Any = None,
             timeout: float = 10.0) -> Any:
        """Call a service and return its response."""
        client = self.node.create_client(srv_type, name)
        try:
            if not client.wait_for_service(timeout_sec=timeout):
                raise AssertionError(f'service {name} not available within {timeout} s')
            future = client.call_async(request if request is not None else srv_type.Request())
            wait_until(future.done, timeout, f'a response from {name}')
            return future.result()
        finally:
            self.node.destroy_client(client)

    def set_parameters(self, node_name: str, values: Mapping[str, Any],
                       timeout: float = 10.0) -> list[Any]:
        """Set parameters of ``node_name`` one by one (like `ros2 param set`);
        the list of rcl_interfaces/SetParametersResult, one per parameter."""
        from rclpy.parameter import Parameter
        client = self._param_client(node_name, timeout)
        future = client.set_parameters([Parameter(k, value=v) for k, v in values.items()])
        wait_until(future.done, timeout, f'set_parameters on {node_name}')
        return list(future.result().results)

    def get_parameters(self, node_name: str, names: Iterable[str],
                       timeout: float = 10.0) -> dict[str, Any]:
        """name → plain value of parameters of ``node_name``."""
        from rclpy.parameter import parameter_value_to_python
        names = list(names)
        client = self._param_client(node_name, timeout)
        future = client.get_parameters(names)
        wait_until(future.done, timeout, f'get_parameters on {node_name}')
        return {n: parameter_value_to_python(v) for n, v in zip(names, future.result().values, strict=True)}

    def _param_client(self, node_name: str, timeout: float) -> Any:
        from rclpy.parameter_client import AsyncParameterClient
        client = AsyncParameterClient(self.node, node_name)
        if not client.wait_for_services(timeout_sec=timeout):
            raise AssertionError(f'parameter services of {node_name} not up in {timeout} s')
        return client


def wait_until(condition: Callable[[], bool], timeout: float, what: str = 'condition',
               poll: float = 0.01) -> None:
    """Poll ``condition`` until true; AssertionError naming ``what`` after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f'timed out after {timeout} s waiting for {what}')
        time.sleep(poll)


def stamp_ns(msg: Any) -> int:
    """Header stamp (or rosgraph Clock) of a message, integer nanoseconds."""
    t = msg.clock if hasattr(msg, 'clock') else msg.header.stamp
    return t.sec * 1_000_000_000 + t.nanosec


__all__ = [
    'STARTUP_TIMEOUT',
    'Inbox',
    'Peer',
    'RosProcess',
    'assert_clean_exit',
    'stamp_ns',
    'start_process',
    'wait_until',
    'write_params_file',
]


#: s of wall time for a few hundred lockstep ticks on a loaded machine
LOCKSTEP_RUN_TIMEOUT = 300.0


def record_lockstep_demo(workdir: Path, values: Mapping[str, Any], targets: Sequence[float],
                         dwell: float, ticks: int, tick_ns: int, name: str) -> Path:
    """demo_controller (the rclpy node) around table_sim in lockstep (``values`` its
    parameters) for ``ticks`` ticks of ``tick_ns``, recorded by table_sim; both stopped
    with SIGINT and checked to exit cleanly. Returns the bag."""
    from sensor_msgs.msg import JointState
    bag = workdir / 'node'
    sim = start_process('table_sim', params={**values, 'lockstep': True,
                                             'real_time_factor': 0.0, 'record': str(bag)},
                        workdir=workdir / 'sim')
    ctl = None
    try:
        with Peer(name) as peer:
            js = peer.subscribe('/joint_states', JointState, transform=stamp_ns)
            ctl = start_process('demo_controller',
                                params={'targets': list(targets), 'dwell': dwell},
                                workdir=workdir / 'ctl')
            js.wait_for(lambda t: t >= ticks * tick_ns, STARTUP_TIMEOUT + LOCKSTEP_RUN_TIMEOUT,
                        f'{ticks} lockstep ticks')
        assert_clean_exit(sim, signal.SIGINT)
        assert_clean_exit(ctl, signal.SIGINT)
    finally:
        sim.kill()
        if ctl is not None:
            ctl.kill()
    return bag
