"""The replay's side of the wire: one rclpy node that plays events into a table_sim.

:class:`ReplayClient` owns the input publishers, ``<node>/tick``, the parameter and reset
clients and the subscriptions to what the target publishes (``mesh_state`` to count its
ticks, ``joint_states`` for where it stands, ``/clock`` when free-running). Callbacks
run on the client's spin thread and only note what arrived under ``_cond``; the caller's
thread waits on it, checking every POLL s for a stop signal and for a spawned node that
ended (:meth:`ReplayClient.check`).

How an event is confirmed inside the node before the next is sent: a command by a
parameter-service round trip (the request travels from this participant after the
messages published before it, and the node's executor serves what arrives in the order
it arrives); a parameter change or reset by its own service reply.
``Publisher.wait_for_all_acked`` would prove only the arrival, and takes up to a writer
heartbeat period per message.
"""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Self, TypeVar

import rclpy
import rclpy.executors
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.subscription import Subscription
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty
from std_srvs.srv import Trigger

from ..errors import ScrewgearError
from ..interface import TICK_TOPIC
from ..sim.events import Command, Event, ParameterChange, Reset, describe
from ..sim.schedule import Schedule
from .messages import INPUT_TYPES, input_message
from .shutdown import spin_executor_until

CONNECT_TIMEOUT = 60.0   # s: a first start compiles the numba core
REPLY_TIMEOUT = 30.0     # s for a service reply
STALL_TIMEOUT = 60.0     # s without a new tick (lockstep) or an advancing /clock
POLL = 0.1               # s between checks for a signal or an ended node while waiting
GRAPH_PERIOD = 1.0       # s of wall time between checks for other publishers
#: s from this client's start before the graph counts as known: Fast DDS repeats a
#: participant's announcement every 3 s once its first burst is over, so a node whose
#: first announcements were lost on a busy machine is named within this window.
DISCOVERY_WINDOW = 3.5
RELIABLE = QoSProfile(depth=10, history=HistoryPolicy.KEEP_LAST,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)

T = TypeVar('T')


class ReplayError(ScrewgearError, RuntimeError):
    """Something that stops a replay; the message says what."""


class Interrupted(ReplayError):
    """SIGINT or SIGTERM arrived."""

    def __init__(self) -> None:
        super().__init__('interrupted')


def _ns(stamp: Any) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class ReplayClient:
    """The replay's node (see the module docstring). ``target``: the node's name,
    relative to this process's namespace unless absolute."""

    def __init__(self, target: str, ros_args: list[str], stop: threading.Event,
                 child: subprocess.Popen | None = None, child_log: Path | None = None,
                 record: Path | None = None) -> None:
        self.target = target
        self.stop = stop
        self.child = child
        self.child_log = child_log
        self.record = record      # where the spawned node records: how to tell it apart
        self.context = rclpy.Context()
        rclpy.init(args=ros_args, context=self.context,
                   signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node('replay_run', context=self.context)
        self._cond = threading.Condition()
        self._dt_ns = 0.0
        self._stamp: int | None = None        # newest joint_states stamp, ns
        self._meshes = 0                      # mesh_state messages: one per tick, never re-sent
        self._mesh_stamp: int | None = None   # the last one's stamp, ns
        self._clock: int | None = None        # newest /clock, ns
        self._clock_moved = time.monotonic()  # when /clock last advanced
        self._clock_sub: Subscription | None = None
        self._graph_checked = 0.0
        self._started = time.monotonic()
        # Publishers first: the node learns our endpoints in the order we create them,
        # so once it has served a request it has matched these (see connect()).
        self.inputs = {topic: self.node.create_publisher(kind, topic, RELIABLE)
                       for topic, kind in INPUT_TYPES.items()}
        self.tick = self.node.create_publisher(Empty, f'{target}/{TICK_TOPIC}', RELIABLE)
        self._joint_states = self.node.create_subscription(
            JointState, 'joint_states', self._on_joint_states, RELIABLE)
        self.node.create_subscription(JointState, 'mesh_state', self._on_mesh_state, RELIABLE)
        self.params = AsyncParameterClient(self.node, target)
        self.reset = self.node.create_client(Trigger, f'{target}/reset')
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=spin_executor_until,
                                        args=(self.executor, self._stop, 0.05), daemon=True,
                                        name='replay_run spin')
        self._thread.start()

    def close(self) -> None:
        """Stop the spin loop and join its thread, then shut the executor down, destroy
        the node and shut the context down: no thread is inside rcl when its executor,
        node or context goes away."""
        self._stop.set()
        self._thread.join(timeout=5.0)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def full_name(self) -> str:
        """The target's fully qualified name."""
        if self.target.startswith('/'):
            return self.target
        return f'{self.node.get_namespace().rstrip("/")}/{self.target}'

    # ------------------------------------------------------------------ callbacks

    def set_dt(self, dt: float) -> None:
        self._dt_ns = dt * 1e9

    def step_of(self, ns: int) -> int:
        return round(ns / self._dt_ns)

    def follow_clock(self) -> None:
        if self._clock_sub is None:
            self._clock_sub = self.node.create_subscription(Clock, '/clock', self._on_clock,
                                                            RELIABLE)

    def _on_joint_states(self, msg: JointState) -> None:
        ns = _ns(msg.header.stamp)
        with self._cond:
            if self._stamp is None or ns > self._stamp:
                self._stamp = ns
                self._cond.notify_all()

    def _on_mesh_state(self, msg: JointState) -> None:
        with self._cond:
            self._meshes += 1
            self._mesh_stamp = _ns(msg.header.stamp)
            self._cond.notify_all()

    def _on_clock(self, msg: Clock) -> None:
        ns = _ns(msg.clock)
        with self._cond:
            if self._clock is None or ns > self._clock:
                self._clock = ns
                self._clock_moved = time.monotonic()
                self._cond.notify_all()

    def _notify(self, *_: Any) -> None:
        with self._cond:
            self._cond.notify_all()

    # ------------------------------------------------------------------ waiting

    def check(self) -> None:
        """Raise if a signal came or the spawned node ended."""
        if self.stop.is_set():
            raise Interrupted()
        if self.child is not None and self.child.poll() is not None:
            raise ReplayError(f'table_sim ended with {self.child.returncode} before the replay '
                              f'was done; its log: {self.child_log}')

    def _wait(self, ready: Callable[[], T | None], timeout: float, what: str) -> T:
        """The first non-None ``ready()`` (called under the lock); ReplayError saying
        ``what`` was missing after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                value = ready()
                if value is not None:
                    return value
                self.check()
                left = deadline - time.monotonic()
                if left <= 0.0:
                    raise ReplayError(what)
                self._cond.wait(min(POLL, left))

    def _result(self, future: Any, what: str) -> Any:
        future.add_done_callback(self._notify)
        self._wait(lambda: True if future.done() else None, REPLY_TIMEOUT,
                   f'{what}: no reply from {self.target} within {REPLY_TIMEOUT:g} s')
        return future.result()

    def connect(self, resets: bool, lockstep: bool, timeout: float = CONNECT_TIMEOUT) -> None:
        """Wait until every input, ``<node>/tick`` and the node's services are matched and
        the node's joint_states (lockstep) or /clock (free-running) have arrived; then
        refuse (:meth:`check_graph`) a graph where the replay would not be alone."""
        needs: list[tuple[str, Callable[[], bool]]] = [
            ('its input topics', lambda: all(p.get_subscription_count() > 0
                                             for p in self.inputs.values())),
            ('its parameter services', self.params.services_are_ready),
        ]
        if resets:
            needs.append(('its reset service', self.reset.service_is_ready))
        if lockstep:
            needs.append((self.tick.topic_name, lambda: self.tick.get_subscription_count() > 0))
            needs.append(('its joint_states', lambda: self._stamp is not None))
        else:
            needs.append(('/clock (publish_clock: true)', lambda: self._clock is not None))
        deadline = time.monotonic() + timeout
        while True:
            with self._cond:
                missing = [name for name, ready in needs if not ready()]
            if not missing:
                break
            self.check()
            if time.monotonic() > deadline:
                raise ReplayError(f'table_sim ({self.full_name}) not reachable within '
                                  f'{timeout:g} s: missing {", ".join(missing)}')
            time.sleep(0.02)
        # Once the node has served a request its readers have matched our writers (the
        # request's writer was created after them).
        self.confirm('connecting')
        self.check_graph()
        # Before the first event: a second node of the target's name that discovery has not
        # named yet would receive the replayed commands too.
        self.settle_graph(self._started + DISCOVERY_WINDOW - time.monotonic())
        if self.record is not None:
            found = self.node_parameters(['record'])['record']
            if found != str(self.record):
                raise ReplayError(f'another node named {self.full_name} answers in this ROS '
                                  f'domain (it records to {found!r}, not to {str(self.record)!r} '
                                  'as the one replay_run started): stop it, or use another '
                                  'namespace or ROS_DOMAIN_ID')

    def check_graph(self) -> None:
        """ReplayError if another node has the target's full name, or anything else
        publishes on the target's input topics or ``<node>/tick``: its commands would mix
        with the replayed ones, its answers release ticks early."""
        self._graph_checked = time.monotonic()
        name = self.full_name
        same = [n for n, ns in self.node.get_node_names_and_namespaces()
                if f'{ns.rstrip("/")}/{n}' == name]
        tables = self._joint_states.get_publisher_count()
        if len(same) > 1 or tables > 1:
            raise ReplayError(f'{max(len(same), tables)} nodes are named {name} (or publish '
                              f'its {self._joint_states.topic_name}) in this ROS domain: the '
                              'replay would drive them all and follow both '
                              '(stop the other, or use another namespace or ROS_DOMAIN_ID)')
        others = [f'{p.topic_name} ({n - 1} other publisher{"s" * (n > 2)})'
                  for p in (*self.inputs.values(), self.tick)
                  if (n := self.node.count_publishers(p.topic_name)) > 1]
        if others:
            raise ReplayError(f'something else publishes to {name}: {", ".join(others)}; its '
                              'commands would mix with the replayed ones (and in lockstep its '
                              'answers release ticks early): stop that controller or tool first')

    def _check_graph_now_and_then(self) -> None:
        if time.monotonic() - self._graph_checked >= GRAPH_PERIOD:
            self.check_graph()

    def settle_graph(self, seconds: float) -> None:
        """:meth:`check_graph` for up to ``seconds`` more: what a node learns of the
        others' names can lag behind the endpoints it has matched."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.check()
            self.check_graph()
            time.sleep(0.1)

    def stand(self) -> tuple[int, int]:
        """Where a lockstep node waits: (step of its joint_states, mesh_state count)."""
        with self._cond:
            assert self._stamp is not None
            return self.step_of(self._stamp), self._meshes

    def wait_tick(self, meshes: int, after_step: int | None = None) -> tuple[int, int]:
        """After an answer: wait for the tick it released, the next ``mesh_state`` (one per
        tick, never re-sent; ``meshes``: how many had come before). The first tick after
        connecting waits for one past ``after_step`` instead (the start's mesh_state, if
        the node published it before we subscribed, may still be on its way). Returns
        (its step, mesh_state count); ReplayError if one answer released two ticks."""
        self._check_graph_now_and_then()

        def ready() -> tuple[int, int] | None:
            if self._meshes <= meshes or self._mesh_stamp is None:
                return None
            step = self.step_of(self._mesh_stamp)
            if after_step is not None:
                return (step, self._meshes) if step > after_step else None
            if self._meshes > meshes + 1:
                raise ReplayError(f'{self.full_name} ran {self._meshes - meshes} ticks for one '
                                  'answer: something else answers its ticks')
            return step, self._meshes
        return self._wait(ready, STALL_TIMEOUT, f'{self.full_name} made no new tick within '
                          f'{STALL_TIMEOUT:g} s of being answered')

    def wait_clock(self, step: int) -> int:
        """Block until the node's /clock reaches ``step``; the step it is at."""
        def ready() -> int | None:
            if self._clock is not None and self.step_of(self._clock) >= step:
                return self.step_of(self._clock)
            if time.monotonic() - self._clock_moved > STALL_TIMEOUT:
                raise ReplayError(f'the /clock of {self.full_name} stood still for '
                                  f'{STALL_TIMEOUT:g} s (last: {self._clock})')
            return None
        self._check_graph_now_and_then()
        return self._wait(ready, float('inf'), 'unreachable')

    # ------------------------------------------------------------------ actions

    def node_parameters(self, names: list[str]) -> dict[str, Any]:
        """The target's values of ``names`` (None for one it lacks)."""
        self._wait(lambda: True if self.params.services_are_ready() else None,
                   CONNECT_TIMEOUT, f'no node {self.full_name} reachable within '
                   f'{CONNECT_TIMEOUT:g} s (its parameter services are not there)')
        response = self._result(self.params.get_parameters(names),
                                f'reading the parameters of {self.full_name}')
        return {n: parameter_value_to_python(v) for n, v in zip(names, response.values, strict=False)}

    def confirm(self, what: str) -> None:
        """A parameter-service round trip: the node has then taken every message this
        client published before (module docstring)."""
        self._result(self.params.get_parameters(['lockstep']), what)

    def set_parameters(self, values: dict[str, Any], what: str) -> None:
        response = self._result(self.params.set_parameters_atomically(
            [Parameter(k, value=v) for k, v in values.items()]), what)
        if not response.result.successful:
            raise ReplayError(f'{what}: {self.full_name} refused {values}: '
                              f'{response.result.reason}')

    def perform(self, event: Event, schedule: Schedule, confirm: bool = True) -> None:
        """Send ``event``; a command with ``confirm`` returns only once the node has
        taken it (and everything published before it); a parameter change or reset
        returns once the node's reply came."""
        what = f'{describe(event)} (step {event.step})'
        if isinstance(event, Command):
            self.inputs[event.topic].publish(input_message(event.topic, event.value))
            if confirm:
                self.confirm(what)
        elif isinstance(event, ParameterChange):
            values = schedule.changed_values(event)     # ROS values already
            if values:
                self.set_parameters(values, f'parameter change at step {event.step}')
        elif isinstance(event, Reset):
            response = self._result(self.reset.call_async(Trigger.Request()), what)
            if not response.success:
                raise ReplayError(f'{what}: {self.full_name} refused: {response.message}')
        else:
            raise ReplayError(f'not a replayable event: {event!r}')

    def answer(self) -> None:
        """Answer the last tick the node published: one Empty on ``<node>/tick`` (while it
        publishes there, the node counts no command as an answer)."""
        self.tick.publish(Empty())


__all__ = [
    'CONNECT_TIMEOUT',
    'REPLY_TIMEOUT',
    'STALL_TIMEOUT',
    'Interrupted',
    'ReplayClient',
    'ReplayError',
]
