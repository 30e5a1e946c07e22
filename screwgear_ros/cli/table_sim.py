"""table_sim: the real-time rotary table plant a controller closes its loop around.

The node is :class:`screwgear_ros.ros.node.TableSim`; this module parses the command line
and runs it until SIGINT or SIGTERM.
"""

from __future__ import annotations

import argparse
import sys

import rclpy
import rclpy.logging
from rclpy.exceptions import ParameterException
from rclpy.signals import SignalHandlerOptions

from ..ros import node as _node
from ..ros import param_dump
from ..ros.node import EXIT_RECORDING_FAILED, NODE_EXECUTOR
from ..ros.shutdown import RosArgumentsError, spin_until, stop_on_signals, without_ros_args
from . import EXIT_ERROR

#: The interpreter's switch interval in the node's process, s (Python's default: 5 ms).
#: Flat out the pacing thread holds the interpreter lock; a thread that wants it back
#: after a C call released it (the recorder's writer after each chunk it compresses and
#: writes, the executor with an arrived command) would wait up to a whole interval for
#: it; a shorter interval makes recording flat out cheaper (bench_recording measures it).
SWITCH_INTERVAL = 0.0005


def _options(args: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog='table_sim', description='The rotary table plant node; its parameters come '
        'after --ros-args (-p name:=value, --params-file FILE).')
    parser.add_argument('--dump-params', metavar='FILE', help='write the parameters in '
                        'force to FILE at start and after every accepted change, as a '
                        'file --params-file reads back exactly')
    return parser.parse_args(without_ros_args(sys.argv if args is None else args)[1:])


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT or SIGTERM; 0 on a clean stop, 2 on bad parameters
    or ROS arguments rcl cannot parse, 3 when the recording failed
    (EXIT_RECORDING_FAILED)."""
    try:
        options = _options(args)
    except RosArgumentsError as error:
        print(f'table_sim: {error}', file=sys.stderr)
        return EXIT_ERROR
    sys.setswitchinterval(SWITCH_INTERVAL)
    stop = stop_on_signals()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node: _node.TableSim | None = None
    try:
        try:
            node = _node.TableSim(stop)
            if options.dump_params:
                log = node.get_logger()
                param_dump.keep_written(node, options.dump_params, log.info, log.error)
        except (ValueError, OSError, ImportError, ParameterException) as error:
            rclpy.logging.get_logger('table_sim').fatal(f'cannot start: {error}')
            return 2
        node.start()
        spin_until(node, stop, executor=NODE_EXECUTOR())
        node.close()                   # the recorder's last writes can still fail
        return node.exit_code()
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()


__all__ = ['EXIT_RECORDING_FAILED', 'NODE_EXECUTOR', 'SWITCH_INTERVAL', 'main']
