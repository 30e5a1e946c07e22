"""linearize [--params YAML] [--torque T] [--load L] [--direction ±1] -o MODEL: the table's
linear model at an operating point (:mod:`screwgear_ros.design.linearize`).

Writes A, B, C, D with the names of the states, inputs and outputs: MODEL.npz (NumPy,
default), a MATLAB .mat file when MODEL ends in .mat, or with ``--format control`` a pickled
``control.StateSpace`` (python-control). Prints the operating point, the contact state it
assumed, each mode (natural frequency in rad/s and Hz, damping ratio, shape) and any
warning that the point sits near a contact change. ``--load hold``: the load that holds the
drive torque (table at rest). ``--mesh frozen`` (static points, `angle` phase): the full
model at its rest angle instead of the mesh's time average.

Exit status: 0 written; 2 not written, with the reason on stderr and never a traceback (a
parameter file or value the node refuses, an operating point with no steady motion, a
point at rest on bearing friction, an output that cannot be written, python-control missing for ``--format control``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..design.errors import DesignError, UsageError
from ..design.friction_state import linearize_with_friction
from ..design.linear_model import LinearModel
from ..design.loop_dynamics import declares_dynamics, with_dynamics
from ..inprocess.simulation import ParameterFileError, file_values, resolve
from ..params.table import ParameterError
from . import EXIT_OK, Failures, interruptible


def load_params(path: str | None):
    """The node's parameters: its defaults, then the file's (the node's validation)."""
    return resolve(file_values(path) if path else {})[0]


def load_settings(path: str | None):
    """The node's settings (sensors, tick rate): its defaults, then the file's."""
    return resolve(file_values(path) if path else {})[1]


def holding_load(params, torque: float, load: str, direction: int) -> float:
    """``load`` as a number, N·m, or for "hold" the load that holds ``torque``."""
    if load == 'hold':
        from ..design.frequency import Input, default_bias
        return default_bias(params, Input.TORQUE, 1.0, torque, None, direction)[1]
    try:
        return float(load)
    except ValueError:
        raise UsageError(f'--load must be a number of N·m or "hold", not {load!r}') \
            from None


def format_modes(model: LinearModel) -> list[str]:
    lines = [f'{"mode":>4}  {"ω_n rad/s":>12}  {"f_n Hz":>10}  {"ζ":>8}  shape']
    for i, mode in enumerate(model.modes(), start=1):
        zeta = f'{mode.damping:8.4f}' if mode.frequency > 0.0 else f'{"—":>8}'
        lines.append(f'{i:>4}  {mode.frequency:12.6g}  {mode.hz:10.6g}  {zeta}  {mode.shape}'
                     + ('' if mode.oscillating or mode.frequency == 0.0 else ' (real pole)'))
    return lines


@interruptible('linearize', 'no model was written')
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='linearize', description="The table's linear model (A, B, C, D) at the preload "
        'equilibrium or in steady motion under a drive torque and load, with its modes.')
    parser.add_argument('--params', metavar='YAML', help="table_sim's parameter file "
                        "(default: the node's defaults, the paper's table)")
    parser.add_argument('--torque', type=float, default=0.0, metavar='T',
                        help='drive torque magnitude, N·m (default 0)')
    parser.add_argument('--load', default='0', metavar='L',
                        help='table load torque, N·m (default 0), or "hold": the load that '
                        'holds the drive torque, table at rest')
    parser.add_argument('--direction', type=int, default=1, choices=(1, -1),
                        help='drive direction (default +1)')
    parser.add_argument('--mesh', choices=('average', 'frozen'), default='average',
                        help='average: the mesh over its period (k_eff, no STE; default); '
                        'frozen: at a static point, the full model at its rest angle')
    parser.add_argument('--dynamics', choices=('declared', 'none'), default='declared',
                        help="declared (default): add the drive lag and the joint sensors' "
                        'delay, speed filter and differenced speed the parameter file '
                        'declares (a drive_torque_delivered state; the sensors in the '
                        'sampled response, as a controller sees the plant); none: the '
                        'mechanics alone')
    parser.add_argument('--friction', choices=('auto', 'ignore'), default='auto',
                        help='bearing friction: auto (default): sliding in steady rotation, '
                        'refused at rest (stuck: no linear model); ignore: the table without '
                        'it, said so')
    parser.add_argument('-o', '--output', required=True, metavar='MODEL',
                        help='output file: .npz (default), .mat (MATLAB), or a pickle with '
                        '--format control')
    parser.add_argument('--format', choices=('npz', 'mat', 'control'), default=None,
                        help='npz | mat | control (python-control StateSpace, pickled); '
                        'default from the suffix of MODEL, npz otherwise')
    args = parser.parse_args(argv)
    out = Path(args.output)
    fmt = args.format or ('mat' if out.suffix == '.mat' else 'npz')
    if fmt == 'mat' and out.suffix != '.mat':
        out = out.with_name(out.name + '.mat')
    failures = Failures('linearize', {
        (ParameterFileError, ParameterError, DesignError): '{exc}',
        OSError: 'cannot write {out}: {why}',
    }, out=out)
    with failures:
        params, settings = load_params(args.params), load_settings(args.params)
        model, _, friction = linearize_with_friction(
            params, args.torque, holding_load(params, args.torque, args.load, args.direction),
            args.direction, args.mesh, ignore=args.friction == 'ignore')
        if args.dynamics == 'declared' and declares_dynamics(params, settings):
            model = with_dynamics(model, params, settings)
        if fmt == 'control':
            try:
                data = model.control_pickle()
            except ImportError:
                raise UsageError('--format control needs python-control '
                                 '(pip install control)') from None
            out.write_bytes(data)
        else:
            model.save(out)
    if failures.code is not None:
        return failures.code
    for line in model.point.describe():
        print(line)
    print('mesh: ' + ('its time average (stiffness k_eff, lever r, no STE)'
                      if model.mesh.value == 'average' else
                      'frozen at the rest angle (stiffness and STE slope there)'))
    print(friction)
    for note in model.notes:
        print(f'dynamics: {note}')
    if args.dynamics == 'declared' and model.sensors is not None:
        print('the sensors act on the samples (delays, filters, differences at the tick '
              'rate): they are in the sampled response (design.margins.held_response), '
              'not in A, B, C, D')
    for line in format_modes(model):
        print(line)
    for warning in model.point.warnings:
        print(f'warning: {warning}')
    print(f'wrote {out} ({fmt}: A {model.a.shape}, B {model.b.shape}, C {model.c.shape}, '
          f'D {model.d.shape}; inputs {", ".join(model.inputs)})')
    return EXIT_OK


if __name__ == '__main__':
    sys.exit(main())
