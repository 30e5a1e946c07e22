"""What a frequency-response measurement will cost, known before it runs, and the bounds
beyond which it is refused.

A stepped sine at f Hz runs at least two periods after its settling, so a low ``--from``
makes long runs: at 1e-4 Hz one point is 2e4 s of simulated time, 4e8 integration steps.
The measurement keeps each run's samples in memory (the outputs of every tick), and a
chirp or a closed loop is one run. :func:`check_cost` refuses a measurement whose largest
run would hold more than ``MAX_BYTES`` of samples, or that makes more than ``MAX_TICKS``
ticks in all (an hour or more), naming the limit; a measurement with more than
``MAX_POINTS`` frequencies is refused before any plan is made.

:attr:`Cost.wall_estimate` is a rough wall time: the ticks times the wall time of one
(``SINE_TICK``: the open-loop runs, one integration step a tick; ``LOOP_TICK``: the closed
loop, the controller asked every tick; both measured on the 2-core machine under load).
The CLI prints it before a measurement expected to take longer than ``ANNOUNCE_AFTER`` s.

Examples
--------
>>> cost = Cost(ticks=1000, largest_run=500, simulated=0.05, bytes=28_000,
...             seconds_per_tick=SINE_TICK)
>>> check_cost(cost) is None and cost.wall_estimate < 1.0
True
"""

from __future__ import annotations

from dataclasses import dataclass

from .errors import MeasurementRefused

#: Most frequencies in one measurement.
MAX_POINTS = 2000
#: Most memory the samples of the largest run may take, bytes.
MAX_BYTES = 1 << 30
#: Most ticks in one measurement (an hour of open-loop measurement, nine of closed loop).
MAX_TICKS = 100_000_000
#: For the estimate: wall time of one tick, s, open loop and closed loop (module docstring).
SINE_TICK, LOOP_TICK = 30e-6, 330e-6
#: The CLI prints the estimate before a measurement expected to take longer, s.
ANNOUNCE_AFTER = 10.0


@dataclass(frozen=True)
class Cost:
    """A measurement's size: ``ticks`` in all, the ``largest_run``'s ticks, the simulated
    time (s), the ``bytes`` the largest run's samples take, and the wall time of one tick
    for the estimate (s)."""

    ticks: int
    largest_run: int
    simulated: float
    bytes: int
    seconds_per_tick: float

    @property
    def wall_estimate(self) -> float:
        """Rough wall time, s (module docstring)."""
        return self.ticks * self.seconds_per_tick

    def describe(self) -> str:
        return (f'{self.simulated:.4g} s simulated in {self.ticks:,} ticks, about '
                f'{self.wall_estimate:.0f} s of wall time; the largest run holds '
                f'{self.bytes / 2**20:.3g} MiB of samples')


def check_points(points: int) -> None:
    """Refuse a number of frequencies beyond ``MAX_POINTS`` (or below 1)."""
    if not 1 <= points <= MAX_POINTS:
        raise MeasurementRefused(f'the number of frequencies must lie in 1 … {MAX_POINTS}, '
                                 f'got {points}')


def check_cost(cost: Cost) -> None:
    """Refuse a measurement beyond the bounds (module docstring), saying which and what
    would raise the lowest frequency into them."""
    if cost.bytes > MAX_BYTES:
        raise MeasurementRefused(
            f'the measurement would hold {cost.bytes / 2**30:.3g} GiB of samples in one run '
            f'({cost.largest_run:,} ticks); the limit is {MAX_BYTES / 2**30:g} GiB: raise '
            'the lowest frequency (--from) or use stepped sines')
    if cost.ticks > MAX_TICKS:
        raise MeasurementRefused(
            f'the measurement would make {cost.ticks:,} ticks ({cost.simulated:.4g} s '
            f'simulated, about {cost.wall_estimate / 3600:.3g} h); the limit is '
            f'{MAX_TICKS:,}: raise the lowest frequency (--from) or use fewer points')


__all__ = ['ANNOUNCE_AFTER', 'LOOP_TICK', 'MAX_BYTES', 'MAX_POINTS', 'MAX_TICKS', 'SINE_TICK',
           'Cost', 'check_cost', 'check_points']
