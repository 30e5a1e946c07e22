"""What the node reports about itself: the status line and the diagnostic values.

Plain strings and numbers from the plant's :class:`~screwgear_ros.sim.plant.Outputs` and
the pacing statistics; the node wraps them into a log line and a
``diagnostic_msgs/DiagnosticStatus``. No ROS here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from functools import lru_cache

from ..interface import ANSWERS
from ..params.table import TableParams
from ..physics.mesh import ContactBranch, mesh_phase
from ..physics.motion import contact_branches
from ..physics.packed import Z1, Z3, PackedModel, pack
from ..physics.quantities import natural_frequency
from .pacing import PacerStats
from .plant import Outputs

#: Diagnostic levels (diagnostic_msgs/DiagnosticStatus).
OK, WARN, ERROR = 0, 1, 2

#: RK4 resolves the mesh's STE and stiffness variation only with enough steps per
#: tooth period: at most 2π/20 rad of mesh phase per step (20 steps per tooth).
MAX_PHASE_PER_STEP = 2.0 * math.pi / 20.0


@lru_cache(maxsize=4)
def _packed(params: TableParams) -> PackedModel:
    """The compiled model's view of ``params``, packed once per parameter set (the
    diagnostics and every table_markers ask; read only here)."""
    return pack(params)


def mesh_phase_rates(params: TableParams, outputs: Outputs) -> tuple[float, float]:
    """φ̇ of mesh 1 and mesh 3 at ``outputs``, rad/s, by the model's mesh phase
    (:func:`screwgear_ros.physics.mesh.mesh_phase`: z·ω in `angle` phase, ω_e in `time`)."""
    p = _packed(params).p
    (th1, _, th3), (w1, _, w3) = outputs.position, outputs.velocity
    return (mesh_phase(th1, w1, p[Z1], outputs.time, p)[1],
            mesh_phase(th3, w3, p[Z3], outputs.time, p)[1])


def mesh_phase_per_step(params: TableParams, outputs: Outputs, dt: float) -> float:
    """Mesh phase advanced per integration step by the faster mesh, rad."""
    r1, r3 = mesh_phase_rates(params, outputs)
    return max(abs(r1), abs(r3)) * dt


def mesh_frequency_ratio(params: TableParams, outputs: Outputs) -> float:
    """Ω = ω_e/ω0 of mesh 1 now: near 1 the STE excites the mesh at its natural
    frequency."""
    return abs(mesh_phase_rates(params, outputs)[0]) / natural_frequency(params)


class Contact(StrEnum):
    """How a mesh is in contact, as diagnostics and markers show it: one member per
    branch of the contact law (:class:`screwgear_ros.physics.mesh.ContactBranch`, same names)."""

    FORWARD = 'forward flank'
    REVERSE = 'reverse flank'
    FORWARD_LIFTING = 'lifting off the forward flank'
    REVERSE_LIFTING = 'lifting off the reverse flank'
    GAP = 'in the gap'
    LINEAR = 'in contact (no backlash)'
    DISENGAGED = 'disengaged'

    @classmethod
    def of(cls, branch: ContactBranch) -> Contact:
        return cls[ContactBranch(branch).name]

    @property
    def touching(self) -> bool:
        """The teeth touch (a flank, lifting off one, or no backlash at all)."""
        return self not in (Contact.GAP, Contact.DISENGAGED)


def contact_states(params: TableParams, outputs: Outputs) -> tuple[Contact, Contact]:
    """Contact of mesh 1 and mesh 3 at ``outputs``: the branches the model's contact law
    is on there (:func:`screwgear_ros.physics.motion.contact_branches`)."""
    branch_1, branch_3 = contact_branches(outputs.time, (*outputs.position, *outputs.velocity),
                                          _packed(params))
    return Contact.of(branch_1), Contact.of(branch_3)


def status_line(outputs: Outputs, achieved_factor: float,
                answers: AnswerCount | None = None) -> str:
    """One line: simulation time, achieved factor, table angle and speed, path, δ, and
    (free-running, while a controller answers) the share of ticks it answered in time."""
    line = (f't = {outputs.time:9.3f} s | x{achieved_factor:5.2f} real time | '
            f'table {outputs.position[1]:+.6f} rad {outputs.velocity[1]:+.5f} rad/s | '
            f'path {outputs.active_path} | TE {outputs.transmission_error * 1e6:+9.3f} um')
    if answers is not None and not math.isnan(answers.rate):
        line += (f' | answers {100.0 * answers.rate:.1f} % in time, '
                 f'{answers.missed} missed since start')
    return line


@dataclass
class AnswerCount:
    """Free-running: how many ticks got the controller's answer within a publish period.

    The node counts each tick (:meth:`tick`: whether an answer to its ``joint_states``
    came before it published the next tick; a later one acts a tick later) and closes a window about once a second
    (:meth:`close`). A window in which no answer came at all has no controller in it (none
    started yet, or it stopped: ``command_timeout`` speaks for that) and is not counted;
    the totals and the rate are over the windows that had one.

    Examples
    --------
    >>> count = AnswerCount(threshold=0.9)
    >>> for k in range(100):
    ...     count.tick(k % 7 != 0)          # every seventh tick unanswered
    >>> count.close()
    True
    >>> count.answered, count.missed, round(count.rate, 2)
    (85, 15, 0.85)
    >>> for k in range(50):
    ...     count.tick(False)               # the controller is gone
    >>> count.close(), count.missed
    (False, 15)
    """

    threshold: float
    answered: int = 0                 # ticks answered in time, over the counted windows
    missed: int = 0                   # ticks not answered in time, over the counted windows
    rate: float = math.nan            # answered share of the last counted window
    window: int = 0                   # ticks in the last counted window
    _window: list[int] = field(default_factory=lambda: [0, 0])   # answered, missed

    def tick(self, answered: bool) -> None:
        """One tick: whether its answer came before the next tick started."""
        self._window[0 if answered else 1] += 1

    def close(self) -> bool:
        """End the window; whether it counted and its rate fell below the threshold."""
        answered, missed = self._window
        self._window = [0, 0]
        if answered == 0:
            return False
        self.answered += answered
        self.missed += missed
        self.window = answered + missed
        self.rate = answered / self.window
        return self.rate < self.threshold

    @property
    def low(self) -> bool:
        """Whether the last counted window's rate is below the threshold."""
        return self.rate < self.threshold    # False while NaN (no controller yet)


@dataclass
class Health:
    """The node's bookkeeping that goes into diagnostics besides the plant state."""

    requested_factor: float
    achieved_factor: float
    pacer: PacerStats
    rejected: dict[str, int] = field(default_factory=dict)   # input topic → count
    fault: str | None = None
    recorder: tuple[int, int] | None = None                  # (written, dropped) or None
    recorder_error: str | None = None
    dt: float = 0.0
    lockstep: bool = False
    command_timed_out: bool = False   # command_timeout zeroed the input until the next command
    commanded: bool = False           # a command was accepted since the start
    waiting: float = 0.0     # lockstep: s of wall time without the controller's answer
    answers: AnswerCount | None = None     # free-running: the controller's answers in time


def diagnostic_values(params: TableParams, outputs: Outputs,
                      health: Health) -> tuple[int, str, list[tuple[str, str]]]:
    """(level, one-line message, key/value pairs) for the node's DiagnosticStatus."""
    phase_step = mesh_phase_per_step(params, outputs, health.dt)
    mesh_1, mesh_3 = contact_states(params, outputs)
    rejected_total = sum(health.rejected.values())
    problems: list[str] = []
    level = OK
    if health.fault is not None:
        level, problems = ERROR, [health.fault]
    else:
        if health.waiting > 0.0:
            level = WARN
            problems.append(f'lockstep: waiting {health.waiting:.0f} s for the controller\'s '
                            f'answer ({ANSWERS}) to the last joint_states')
        if not health.lockstep and health.requested_factor > 0.0 and (
                health.achieved_factor < 0.95 * health.requested_factor):
            level = WARN
            problems.append(f'cannot keep up: real-time factor {health.achieved_factor:.3f} '
                            f'< {health.requested_factor:g} requested')
        if phase_step > MAX_PHASE_PER_STEP:
            level = WARN
            problems.append(f'mesh phase advances {phase_step:.3f} rad per step '
                            f'(> {MAX_PHASE_PER_STEP:.3f}): dt too large for this speed')
        answers = health.answers
        if answers is not None and answers.low:
            level = WARN
            problems.append(f'the controller answered {100.0 * answers.rate:.1f} % of the '
                            f'ticks in time (< {100.0 * answers.threshold:g} % '
                            f'min_answer_rate; {answers.missed} missed since start): a late '
                            'answer acts a tick later')
        if health.recorder is not None and health.recorder[1] > 0:
            level = WARN
            problems.append(f'recorder dropped {health.recorder[1]} messages')
        if health.recorder_error is not None:
            level = WARN
            problems.append(f'recording failed: {health.recorder_error}')
    # Neither is a problem: the table idles as it should. Before the first command
    # nothing has timed out: the input is zero because none ever came.
    timed_out = health.command_timed_out and health.commanded
    if not health.commanded:
        problems.append('waiting for the first command: drive torque and load are zero '
                        'until one comes')
    elif timed_out:
        problems.append('no command within command_timeout: drive torque and load are zero '
                        'until the next command')
    message = '; '.join(problems) if problems else 'running'
    p = health.pacer
    values = [
        ('simulation_time_s', f'{outputs.time:.6f}'),
        ('step', str(outputs.step)),
        ('real_time_factor_requested', f'{health.requested_factor:g}'),
        ('real_time_factor_achieved', f'{health.achieved_factor:.4f}'),
        ('overruns', str(p.overruns)),
        ('resyncs', str(p.resyncs)),
        ('time_given_up_s', f'{p.lost_time:.6f}'),
        ('max_lag_s', f'{p.max_lag:.6f}'),
        ('rejected_inputs', str(rejected_total)),
        *((f'rejected_{topic}', str(n)) for topic, n in sorted(health.rejected.items())),
        ('active_path', str(outputs.active_path)),
        ('mesh_1_contact', str(mesh_1)),
        ('mesh_3_contact', str(mesh_3)),
        ('mesh_phase_per_step_rad', f'{phase_step:.5f}'),
        ('mesh_frequency_ratio', f'{mesh_frequency_ratio(params, outputs):.4f}'),
        ('fault', health.fault or ''),
        ('lockstep', 'true' if health.lockstep else 'false'),
        ('command_timed_out', 'true' if timed_out else 'false'),
        ('waiting_for_first_command', 'false' if health.commanded else 'true'),
        ('lockstep_waiting_s', f'{health.waiting:.1f}'),
    ]
    if health.answers is not None:       # free-running
        rate = health.answers.rate
        values += [('answers_in_time', str(health.answers.answered)),
                   ('answers_missed', str(health.answers.missed)),
                   ('answer_rate', '' if math.isnan(rate) else f'{rate:.4f}')]
    if health.recorder is not None:
        values += [('recorder_written', str(health.recorder[0])),
                   ('recorder_dropped', str(health.recorder[1]))]
    return level, message, values


__all__ = [
    'ERROR',
    'MAX_PHASE_PER_STEP',
    'OK',
    'WARN',
    'AnswerCount',
    'Contact',
    'Health',
    'contact_states',
    'diagnostic_values',
    'mesh_frequency_ratio',
    'mesh_phase_per_step',
    'mesh_phase_rates',
    'status_line',
]
