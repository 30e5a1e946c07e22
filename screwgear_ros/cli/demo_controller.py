"""demo_controller: a PID position loop on the table angle, closed around table_sim.

The node is :class:`screwgear_ros.ros.demo_controller.DemoControllerNode`; this module runs
it until SIGINT or SIGTERM, then sends a zero effort, leaving the table unforced.
"""

from __future__ import annotations

import warnings

import rclpy
from rclpy.signals import SignalHandlerOptions

from ..ros import demo_controller as _node
from ..ros.shutdown import spin_until, stop_on_signals


def main(args: list[str] | None = None) -> int:
    """Run until SIGINT or SIGTERM; exit 0."""
    stop = stop_on_signals()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    try:
        node = _node.DemoControllerNode()
        spin_until(node, stop)
        node.stop_driving()              # leave the table unforced
        return 0
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


def __getattr__(name: str) -> object:
    """The node class under its old path, for one release."""
    if name == 'DemoController':
        warnings.warn('screwgear_ros.cli.demo_controller.DemoController moved to '
                      'screwgear_ros.ros.demo_controller.DemoControllerNode', DeprecationWarning,
                      stacklevel=2)
        return _node.DemoControllerNode
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


__all__ = ['main']
