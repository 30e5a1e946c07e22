"""run_scenario SCENARIO.yaml [--params FILE] [--record BAG] [--plot PNG]: run a scenario
in-process.

Runs the scenario file (docs/scenarios.md) through the node's own simulation loop in
this process, with no ROS graph and as fast as the machine goes, and prints the run's
metrics (:mod:`screwgear_ros.inprocess.metrics`). ``--record BAG`` records the run exactly as
table_sim would (``check_run``, ``replay_run`` and ``plot_run`` take it); ``--plot PNG``
draws it as plot_run does. ``--params FILE``: table_sim's parameter file under the
scenario's own ``parameters`` (in the place of the scenario's ``parameters_file``). The
first line printed names the parameter file the run starts from, or says that it runs on
the node's defaults (the paper's ideal table).

Exit status: 0 the run went to its end; 1 the model diverged (the metrics say when);
2 the run could not be made, with the reason on stderr and never a traceback: a
scenario file that cannot be read or is invalid (the message names its line), a
controller that cannot be loaded or that fails or answers with a command the node would
refuse, BAG that exists, a figure that cannot be written.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from ..inprocess.metrics import MetricFailed, format_metrics
from ..inprocess.scenario import ScenarioError, load_scenario
from ..inprocess.scenario_controller import ControllerFailed
from ..sim.commands import InputRejected
from . import EXIT_OK, Failures, interruptible

#: The model diverged (the metrics say when).
EXIT_FAULT = 1


@interruptible('run_scenario', 'the run was cut short; a --record bag is closed with the '
               'ticks run so far (none is left if the recording had not started)')
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='run_scenario', description='Run a scenario file in-process (no ROS graph, as '
        'fast as possible) and print its metrics: max |TE|, RMS tracking error, overshoot, '
        'settling time, lost motion at each reversal, peak mesh forces, faults.')
    parser.add_argument('scenario', help='scenario YAML (docs/scenarios.md)')
    parser.add_argument('--params', metavar='FILE', help="table_sim's parameter file the "
                        "scenario's parameters go on top of (replaces the scenario's "
                        "parameters_file; default: that file, else the node's defaults)")
    parser.add_argument('--record', metavar='BAG', help='record the run to this new rosbag2 '
                        'directory, as table_sim records')
    parser.add_argument('--plot', metavar='PNG', help='draw the run (as plot_run) into this '
                        'figure file')
    args = parser.parse_args(argv)
    failures = Failures('run_scenario', {
        (ScenarioError, ControllerFailed, MetricFailed): '{exc}',
        InputRejected: "{scenario}: the controller answered with a command the node "
                       "refuses: {exc}",
    }, unexpected='{scenario}: {kind}: {exc}', scenario=args.scenario)
    with failures:
        scenario = load_scenario(args.scenario, args.params)
        print(f'{args.scenario}: {scenario.table()}', flush=True)
        if args.record and Path(args.record).exists():
            raise FileExistsError(f'{args.record} exists; a recording goes to a new directory')
        plot = None
        if args.plot:
            from ..runs import plot as plotting
            plot = plotting.output_path(args.plot)
        with tempfile.TemporaryDirectory(prefix='run_scenario_') as scratch:
            record = args.record or (str(Path(scratch) / 'run') if plot else None)
            simulation = scenario.simulation()
            simulation.reset()             # the compiled model loaded before the clock starts
            started = time.perf_counter()
            run = scenario.run(record=record, simulation=simulation)
            wall = time.perf_counter() - started
            metrics = scenario.metrics(run)
            if plot is not None and record is not None:     # a plot is drawn from a bag
                from ..bag.reader import read_run
                plotting.save(plotting.run_figure(read_run(record)), plot)
    if failures.code is not None:
        return failures.code
    ticks = len(run) - 1
    print(f'{args.scenario}: {run.time[-1]:.4f} s of simulation, {ticks} ticks in '
          f'{wall:.2f} s ({ticks / wall if wall > 0 else float("inf"):.0f} ticks/s)')
    print(format_metrics(metrics))
    for step, message in run.rejected[:5]:
        print(f'refused at step {step}: {message}')
    if args.record:
        print(f'recorded to {args.record}')
    if plot is not None:
        print(f'plotted to {plot}')
    return EXIT_FAULT if run.fault else EXIT_OK


if __name__ == '__main__':
    sys.exit(main())
