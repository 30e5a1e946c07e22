"""Start and stop a rclpy shell in an order that cannot race.

rclpy's own signal handler invalidates the context the moment Ctrl-C arrives, while
a pacing thread or timer may still publish ("publisher's context is invalid"). The
shells instead call ``rclpy.init(..., signal_handler_options=SignalHandlerOptions.NO)``
and let SIGINT/SIGTERM only set an event (:func:`stop_on_signals`); after the loop
ends they stop their own threads, then destroy nodes, then shut rclpy down.
"""

from __future__ import annotations

import signal
import threading

from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node


def stop_on_signals() -> threading.Event:
    """An event that SIGINT and SIGTERM set (and nothing else)."""
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    return stop


def spin_until(node: Node, stop: threading.Event, period: float = 0.1) -> None:
    """Serve ``node``'s callbacks until ``stop`` is set (checked every ``period`` s)."""
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    while not stop.is_set():
        executor.spin_once(timeout_sec=period)


__all__ = ['stop_on_signals', 'spin_until']
