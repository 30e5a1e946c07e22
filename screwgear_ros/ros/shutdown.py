"""Start and stop a rclpy shell in an order that cannot race.

rclpy's own signal handler invalidates the context the moment Ctrl-C arrives, while
a pacing thread or timer may still publish ("publisher's context is invalid"). The
shells instead call ``rclpy.init(..., signal_handler_options=SignalHandlerOptions.NO)``
and let SIGINT/SIGTERM only set an event (:func:`stop_on_signals`); after the loop
ends they stop their own threads, then destroy nodes, then shut rclpy down.

A stop signal is answered by exit status 0 however late it comes, also during the
interpreter's teardown (:func:`stop_on_signals`).
"""

from __future__ import annotations

import atexit
import os
import re
import signal
import threading

from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.utilities import remove_ros_args

from ..errors import ScrewgearError

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def stop_on_signals() -> threading.Event:
    """An event that SIGINT and SIGTERM set (and nothing else). Main thread only.

    The event is not set by a Python signal handler: such a handler runs on the main
    thread between two bytecodes, possibly while that thread holds the event's own lock
    (``Event.set``/``wait`` in ``close()``), or inside the handler of the previous
    signal (a killed parent sends ``PR_SET_PDEATHSIG`` once per thread it loses), and
    ``Event.set`` there waits forever for a lock its own thread holds. Seen: a node
    orphaned by a killed replay_run hung with three nested handlers. Instead the C
    handler writes the signal's number to a pipe (:func:`signal.set_wakeup_fd`, no lock,
    async-signal-safe) and a daemon thread sets the event when it reads SIGINT or
    SIGTERM there; the Python handlers do nothing.

    A burst of stop signals may outlast the process's own stop: the last ones can come
    while the interpreter tears itself down. That teardown resets every Python-level
    handler to the default action once the ``atexit`` callbacks have run (and leaves
    ignored signals ignored), so a stop signal arriving then would kill the stopping
    process (status -2, a shell's 130). The last ``atexit`` callback therefore ignores
    the stop signals: until then the handler above takes them, from then on the kernel
    drops them, and nothing is skipped on the way out (``os._exit`` would skip the
    other ``atexit`` callbacks and the flushing of buffered output). Registered before
    the callbacks a shell adds later, it runs after them (``atexit`` runs last in,
    first out), so stop signals stay harmless through those too.
    """
    stop = threading.Event()
    read, write = os.pipe()
    os.set_blocking(write, False)
    signal.set_wakeup_fd(write, warn_on_full_buffer=False)
    for signum in STOP_SIGNALS:
        signal.signal(signum, _noted)
    atexit.unregister(_ignore_stop_signals)
    atexit.register(_ignore_stop_signals)

    def watch() -> None:
        while True:
            if any(number in STOP_SIGNALS for number in os.read(read, 64)):
                stop.set()

    threading.Thread(target=watch, name='stop on signals', daemon=True).start()
    return stop


def _noted(signum: int, frame: object) -> None:
    """Python's side of a stop signal: nothing (the wakeup pipe carries it)."""


def _ignore_stop_signals() -> None:
    """Ignore the stop signals from here to the end of the process (see above)."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


class RosArgumentsError(ScrewgearError, ValueError):
    """A command line whose ROS arguments (after ``--ros-args``) rcl cannot parse; the
    message is rcl's reason, in one line."""


#: rcl's source locations in its error text (``, at /project/src/rcl/arguments.c:352``).
_RCL_WHERE = re.compile(r',? at \S+:\d+')


def without_ros_args(argv: list[str]) -> list[str]:
    """``argv`` (program name first) without its ROS arguments, as rclpy's
    ``remove_ros_args`` gives it, once rcl has parsed them all.

    Parameters
    ----------
    argv : list of str
        The command line, program name first.

    Returns
    -------
    list of str
        The arguments that are not ROS arguments, program name first.

    Raises
    ------
    RosArgumentsError
        rcl cannot parse a ROS argument (``-p name:=`` with no value, ``-r x``, a
        ``--params-file`` that is missing or not a parameter file, an unknown flag):
        rcl's reason in one line, before anything has started.

    Examples
    --------
    >>> without_ros_args(['table_sim', '--dump-params', 'p.yaml', '--ros-args', '-p', 'dt:=1e-4'])
    ['table_sim', '--dump-params', 'p.yaml']
    """
    try:
        return remove_ros_args(argv)
    except _rclpy.UnknownROSArgsError as exc:
        raise RosArgumentsError(f'unknown ROS arguments: {exc}') from None
    except _rclpy.RCLError as exc:
        reason = _RCL_WHERE.sub('', str(exc)).replace('. Error: error not set', '')
        reason = reason.removeprefix('Failed to parse ROS arguments: ')
        raise RosArgumentsError('invalid ROS arguments: '
                                + ' '.join(reason.split())) from None


def spin_until(node: Node, stop: threading.Event, period: float = 0.1,
               executor: Executor | None = None) -> None:
    """Serve ``node``'s callbacks until ``stop`` is set (checked every ``period`` s), on
    ``executor`` (default: a new SingleThreadedExecutor)."""
    executor = SingleThreadedExecutor() if executor is None else executor
    executor.add_node(node)
    spin_executor_until(executor, stop, period)


def spin_executor_until(executor: Executor, stop: threading.Event,
                        period: float = 0.1) -> None:
    """Serve ``executor``'s callbacks until ``stop`` is set (checked every ``period`` s).
    A shell that spins on a thread sets ``stop`` and joins it before it shuts the
    executor down: rclpy destroys guard conditions a running spin still uses."""
    while not stop.is_set():
        executor.spin_once(timeout_sec=period)


__all__ = ['STOP_SIGNALS', 'RosArgumentsError', 'spin_executor_until', 'spin_until',
           'stop_on_signals', 'without_ros_args']
