"""demo_controller: a PID position loop on the table angle, closed around table_sim.

The node is :class:`screwgear_ros.ros.demo_controller.DemoController`; this module runs
it until SIGINT or SIGTERM, then sends a zero effort, leaving the table unforced.
"""

from __future__ import annotations

import sys
import warnings

import rclpy
from rclpy.signals import SignalHandlerOptions

from ..ros import demo_controller as _node
from ..ros.shutdown import RosArgumentsError, spin_until, stop_on_signals, without_ros_args
from . import EXIT_ERROR


def main(args: list[str] | None = None) -> int:
    """Run until SIGINT or SIGTERM; exit 0 (2: ROS arguments rcl cannot parse)."""
    try:
        without_ros_args(sys.argv if args is None else args)
    except RosArgumentsError as error:
        print(f'demo_controller: {error}', file=sys.stderr)
        return EXIT_ERROR
    stop = stop_on_signals()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    try:
        node = _node.DemoController()
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
                      'screwgear_ros.ros.demo_controller.DemoController', DeprecationWarning,
                      stacklevel=2)
        return _node.DemoController
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


__all__ = ['main']
