"""frequency_response [--params YAML] [--input torque|load] [--output NAME...] [--from HZ]
[--to HZ] [--points N] [--amplitude A] [--method sine|chirp] -o OUT: the table's frequency
response measured by simulation around an operating point, beside the linear model's
(:mod:`screwgear_ros.design.frequency`).

Writes OUT.csv (frequency_hz, output, magnitude, phase_deg, magnitude_linear,
phase_deg_linear, coherence; magnitudes in output units per N·m) and OUT.png (Bode plot,
measured and linear, the modes marked).

Exit status: 0 written; 2 not written, with the reason on stderr and never a traceback (a
parameter file or value the node refuses, an operating point with no steady motion, a
request the measurement cannot do, an output that cannot be written); 1 the model
diverged during a measurement.

``--controller demo|module:callable`` closes the loop (:mod:`screwgear_ros.design.
closed_loop`): the sine is added to the controller's effort, and the rows are the loop
gain, the sensitivity and each output's closed-loop response of the sampled-data loop, up
to 0.9 of the tick rate's Nyquist frequency; it prints the gain margin, the phase margin
and the peak |S| read off the measured loop gain (and off the loop with the linear plant).
``module`` is imported as ``python -m`` imports one (the current directory first);
``callable`` is a factory (its first parameter named ``setpoint``: called once with the
setpoint) or the controller itself (called every tick with an observation).

Bounds (:mod:`screwgear_ros.design.budget`): at most 2000 frequencies; a measurement whose
largest run would hold more than 1 GiB of samples, or that makes more than 1e8 ticks, is
refused with the limit; one expected to take more than 10 s prints its estimate first.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ..design.budget import ANNOUNCE_AFTER, MAX_POINTS, Cost
from ..design.closed_loop import make_controller, measure_loop
from ..design.errors import DesignError, UsageError
from ..design.frequency import Input, Method, measure
from ..design.linear_model import OUTPUTS
from ..inprocess.scenario_controller import CheckedController, ControllerFailed
from ..inprocess.simulation import ParameterFileError, file_values, resolve
from ..params.table import ParameterError
from . import EXIT_OK, Failures, interruptible
from .linearize import format_modes

#: The model diverged during a measurement.
EXIT_FAULT = 1


@interruptible('frequency_response', 'no CSV or figure was written')
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='frequency_response', description='Measure the frequency response of the table '
        'by simulation (stepped sines or a chirp) around an operating point, beside its linear '
        'model; write OUT.csv and a Bode plot OUT.png.')
    parser.add_argument('--params', metavar='YAML', help="table_sim's parameter file "
                        "(default: the node's defaults, the paper's table)")
    parser.add_argument('--input', choices=[i.value for i in Input], default='torque',
                        help='drive torque (default) or table load')
    parser.add_argument('--output', nargs='+', default=['table_angle'], metavar='NAME',
                        choices=OUTPUTS, help=f'outputs: {", ".join(OUTPUTS)} '
                        '(default table_angle)')
    parser.add_argument('--from', dest='low', type=float, default=1.0, metavar='HZ',
                        help='lowest frequency, Hz (default 1)')
    parser.add_argument('--to', dest='high', type=float, default=500.0, metavar='HZ',
                        help='highest frequency, Hz (default 500)')
    parser.add_argument('--points', type=int, default=30, metavar='N',
                        help='frequencies, log-spaced (default 30)')
    parser.add_argument('--amplitude', type=float, default=10.0, metavar='A',
                        help='input amplitude, N·m (default 10)')
    parser.add_argument('--torque', type=float, default=None, metavar='T',
                        help='bias drive torque, N·m (default: twice the amplitude for the '
                        'torque input, 0 for the load input)')
    parser.add_argument('--load', type=float, default=None, metavar='L',
                        help='bias load, N·m (default: the load that holds the bias torque, '
                        'table at rest)')
    parser.add_argument('--direction', type=int, default=1, choices=(1, -1))
    parser.add_argument('--method', choices=[m.value for m in Method], default='sine',
                        help='stepped sines (default) or one exponential chirp')
    parser.add_argument('--mesh', choices=('average', 'frozen'), default='average',
                        help="the linear model's mesh (see linearize --mesh; default average)")
    parser.add_argument('--controller', metavar='demo|module:callable',
                        help='close the loop with this controller holding the table: the demo '
                        'PID, or module:callable from the current directory or the Python '
                        'path, a factory whose first parameter is named setpoint (called as '
                        'scenarios call it) or the controller itself (called every tick with '
                        'an observation); measures the loop gain, the sensitivity and the '
                        'closed-loop response, and the margins')
    parser.add_argument('-o', '--out', required=True, metavar='OUT',
                        help='output stem: OUT.csv and OUT.png')
    args = parser.parse_args(argv)
    stem = Path(args.out)
    if stem.suffix in ('.csv', '.png'):
        stem = stem.with_suffix('')
    failures = Failures('frequency_response', {
        (ParameterFileError, ParameterError, DesignError, ControllerFailed): '{exc}',
        FloatingPointError: ('{exc}', EXIT_FAULT),
        OSError: 'cannot write {stem}: {why}',
    }, stem=stem)
    with failures:
        if not (args.low > 0.0 and args.high >= args.low and np.isfinite(args.high)):
            raise UsageError(f'--from {args.low:g} and --to {args.high:g} must be '
                             'finite with 0 < from <= to')
        if not 1 <= args.points <= MAX_POINTS:
            raise UsageError(f'--points must lie in 1 … {MAX_POINTS}, got {args.points}')
        if not stem.parent.is_dir():
            raise UsageError(f'{stem.parent} is not a directory')
        params, settings = resolve(file_values(args.params) if args.params else {})
        frequencies = np.geomspace(args.low, args.high, args.points)
        loop = None
        if args.controller:
            if args.input != 'torque' or args.method != 'sine':
                raise UsageError('--controller measures with stepped sines added to '
                                 "the controller's torque (--input torque, --method "
                                 'sine)')
            name = f'--controller {args.controller}'
            try:
                controller = CheckedController(name, make_controller(args.controller,
                                                                     settings))
            except (DesignError, ControllerFailed):
                raise
            except Exception as exc:  # noqa: BLE001 - the user's factory: named, not raw
                raise ControllerFailed(f'{name}: its factory raised {type(exc).__name__}: '
                                       f'{exc}; a factory returns the controller, a '
                                       'callable') from None
            loop = measure_loop(params, settings, controller, outputs=args.output,
                                frequencies=frequencies, amplitude=args.amplitude,
                                torque=args.torque, load=args.load, direction=args.direction,
                                mesh=args.mesh, name=args.controller, announce=_announce)
            result = loop.response
        else:
            result = measure(params, settings, input=args.input, outputs=args.output,
                             frequencies=frequencies, amplitude=args.amplitude,
                             torque=args.torque, load=args.load, direction=args.direction,
                             method=args.method, mesh=args.mesh, announce=_announce)
        csv_path, png_path = stem.with_name(stem.name + '.csv'), stem.with_name(stem.name + '.png')
        result.write_csv(csv_path)
        (loop or result).save_figure(png_path)
    if failures.code is not None:
        return failures.code
    model = result.model
    for line in model.point.describe():
        print(line)
    for line in format_modes(model):
        print(line)
    for note in model.notes:
        print(f'linear plant: {note}')
    for note in result.notes:
        print(f'warning: {note}')
    worst = float(np.min(result.coherence))
    print(f'{len(result.frequency)} frequencies × {len(result.outputs)} outputs, '
          f'{args.method}: {result.simulated:.3f} s simulated in {result.wall:.2f} s; lowest '
          f'coherence {worst:.4f}')
    if loop is not None:
        print(f'closed loop ({args.controller}), measured: {loop.margins.describe()}')
        print(f'closed loop ({args.controller}), linear plant: {loop.margins_linear.describe()}')
    print(f'wrote {csv_path} and {png_path}')
    return EXIT_OK


def _announce(cost: Cost) -> None:
    """Say what a long measurement will take before it starts."""
    if cost.wall_estimate > ANNOUNCE_AFTER:
        print(f'frequency_response: measuring {cost.describe()}', flush=True)


if __name__ == '__main__':
    sys.exit(main())
