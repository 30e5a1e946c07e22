"""How far a recorded signal may be from the reference: RK4's own error, estimated.

Tolerance, per signal: the node integrates with classical RK4 at dt. Its global
error e(dt) is estimated by Richardson's comparison with RK4 at dt/2 over the same
recorded inputs: for a method of order p, |RK4(dt) − RK4(dt/2)| = (1 − 2^−p)·|e(dt)|,
i.e. the error is 16/15 of the estimate at order 4. With contact changes located
inside the steps (setting ``contact_location``, on since it exists: docs/model_notes.md
§12) RK4 keeps order 4 through backlash impacts too: on the test scenarios re-recorded
with it (conventional reversals with impacts among them) and on a 60 s run with
reversals and load steps, the error was 1.07 times the estimate on every signal. The
tolerance is then ``SAFETY`` (1.5: order ≥ 1.6 everywhere would still pass) × the
largest estimate over the run. A recording made with the fixed step (``contact_location``
off, or recorded before it existed) drops to order 0.3–1 at every impact, where the
error reached 2.0 times the estimate on the checked-in conventional bag: such runs keep
``SAFETY_FIXED_STEP`` (4). Never less than ``FLOOR_REL`` × the signal's largest
magnitude (10× the looser of the reference's two rtols, so float round-off never
fails a run).

The RK4 replay at dt/2 (:func:`fine_replay`) runs in a second process (forked) while
this one replays at dt and solves the reference; with one core, or ``parallel=False``,
it runs after them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...bag.reader import RecordedRun
from ...numerics.reference import RTOL
from ..replay_in_process import replay_in_process

#: Tolerance = SAFETY × Richardson estimate of RK4's error (contact changes located).
SAFETY = 1.5
#: The same for a run recorded with plain fixed-step RK4 (impacts lower its order).
SAFETY_FIXED_STEP = 4.0
#: Smallest tolerance relative to the signal's largest magnitude.
FLOOR_REL = 10.0 * RTOL
#: Smallest absolute tolerance per unit (round-off of a value near zero).
FLOOR_ABS = {'rad': 1e-12, 'rad/s': 1e-12, 'N·m': 1e-9, 'm': 1e-15, 'm/s': 1e-15, 'N': 1e-9}
#: Longest reference solve between restarts, s of simulation (progress granularity).
BLOCK_SECONDS = 0.25
#: The reference is solved at RTOL / REFERENCE_REFINE (atol alike) and at RTOL: the run
#: is judged against the tighter solution, whose own error is taken to be their
#: difference / (REFERENCE_REFINE − 1) (a global error proportional to the tolerance).
REFERENCE_REFINE = 10.0
#: Bits of the table encoder the table angle's error is stated against: a 26-bit encoder,
#: what a precision rotary table carries (the realistic preset's). The simulation's own
#: error should stay below one of its counts, or a controller would see the integrator.
TABLE_ENCODER_BITS = 26
#: One count of that encoder, rad.
TABLE_ENCODER_COUNT = 2.0 * math.pi / 2**TABLE_ENCODER_BITS


@dataclass(frozen=True)
class SignalError:
    """How far one recorded signal is from what it is judged against, in ``unit``."""

    name: str
    unit: str
    max_error: float
    rms_error: float
    at_time: float          # simulation time of the largest error, s
    tolerance: float
    estimate: float = math.nan   # check_run: Richardson estimate of RK4's error, max over the run
    times: np.ndarray | None = field(default=None, compare=False, repr=False)  # samples, s
    errors: np.ndarray | None = field(default=None, compare=False, repr=False)  # |error| there
    #: check_run: what the reference's own error is taken to be (how far its solutions at
    #: two tolerances differ, max over the run); 0 where it is judged exact
    reference_error: float = 0.0

    @property
    def ok(self) -> bool:
        """Within tolerance whatever the reference's own error."""
        return self.max_error + self.reference_error <= self.tolerance

    @property
    def undecided(self) -> bool:
        """Neither ok nor out of tolerance: within the reference's own error of it."""
        return not self.ok and self.max_error - self.reference_error <= self.tolerance


def signal_error(name: str, unit: str, error: np.ndarray, times: np.ndarray, tolerance: float,
                 estimate: float = math.nan, reference_error: float = 0.0) -> SignalError:
    """Max (a non-finite error counts as infinite) and RMS of ``error`` sampled at ``times`` (s);
    the record keeps both arrays (``check_run --plot`` draws them)."""
    error = np.where(np.isfinite(error), error, np.inf)
    worst = int(np.argmax(error))
    return SignalError(name, unit, float(error[worst]), float(np.sqrt(np.mean(np.square(error)))),
                       float(times[worst]), tolerance, estimate, times, error, reference_error)


def fine_replay(run: RecordedRun, forked: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(joint_states rows, transmission errors) of the RK4 replay of ``run`` at dt/2
    (``forked``: :class:`~.forked.Forked`'s flag, unused: the replay reports nothing)."""
    fine = replay_in_process(run, 2)
    return np.ascontiguousarray(fine.joint_states), np.ascontiguousarray(fine.transmission_error)
