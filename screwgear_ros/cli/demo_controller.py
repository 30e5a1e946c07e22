"""demo_controller: a PID position loop on the table angle, closed around table_sim.

The node is :class:`screwgear_ros.ros.demo_controller.DemoControllerNode`; this module runs
it until SIGINT or SIGTERM, then sends a zero effort, leaving the table unforced.
"""

from __future__ import annotations

import argparse
import sys

import rclpy
from rclpy.signals import SignalHandlerOptions

from ..ros import demo_controller as _node
from ..ros.shutdown import RosArgumentsError, spin_until, stop_on_signals, without_ros_args
from ..sim.control import DemoGains
from . import EXIT_ERROR


def _options(args: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog='demo_controller',
        description='A PID position loop on the table angle, closed around table_sim: '
        'it answers each new joint_states stamp with one cmd_effort, following a '
        'back-and-forth target profile. Its ROS parameters come after --ros-args '
        f'(-p name:=value): {", ".join(DemoGains.names())}. SIGINT or SIGTERM sends a '
        'zero effort and stops it.')
    parser.add_argument('--duration', type=_seconds, metavar='SECONDS',
                        help='simulated seconds to control: the first joint_states stamped '
                        'at or after SECONDS is not answered and the controller exits 0. '
                        'With table_sim in lockstep the run stops exactly at that stamp '
                        '(default: until SIGINT or SIGTERM)')
    return parser.parse_args(without_ros_args(sys.argv if args is None else args)[1:])


def _seconds(text: str) -> float:
    value = float(text)
    if not value > 0.0 or value == float('inf'):
        raise argparse.ArgumentTypeError(f'must be a finite number of seconds > 0, got {text}')
    return value


def main(args: list[str] | None = None) -> int:
    """Run until SIGINT or SIGTERM, or until ``--duration`` simulated seconds; exit 0 (2:
    ROS arguments rcl cannot parse)."""
    try:
        options = _options(args)
    except RosArgumentsError as error:
        print(f'demo_controller: {error}', file=sys.stderr)
        return EXIT_ERROR
    stop = stop_on_signals()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    try:
        node = _node.DemoControllerNode(stop_at=options.duration, done=stop)
        spin_until(node, stop)
        if not node.finished:
            node.stop_driving()          # leave the table unforced
        return 0
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


__all__ = ['main']
