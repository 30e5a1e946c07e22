"""table_sim's pacing thread: it ticks the session, paces the ticks and hands them out.

One compiled call per tick (:meth:`Session.tick`), a sleep to the tick's absolute
deadline (:class:`screwgear_ros.sim.pacing.Pacer`), then :class:`~screwgear_ros.runs.run_io.RunIO`
publishes and records the tick. With ``lockstep`` the thread starts tick k+1 only once
the controller has answered tick k's ``joint_states`` (:class:`~screwgear_ros.sim.pacing.AnswerGate`),
re-sending it while it waits; free-running, it counts the ticks whose answer came too
late (:class:`~screwgear_ros.sim.status.AnswerCount`). It logs what a person should know
about a tick, publishes ``/diagnostics``, and stops the node at ``duration``.

The session, the RunIO, the pacer, the rate limiter and the health record belong to this
thread (see :mod:`screwgear_ros.ros.node` for what the executor thread may touch).
"""

from __future__ import annotations

import threading
import time
import traceback
from collections.abc import Mapping
from typing import Any

from ..interface import ANSWERS
from ..runs.run_io import RunIO
from ..sim.events import Command, Reset
from ..sim.pacing import AnswerGate, FactorMeter, Pacer
from ..sim.ratelimit import RateLimiter
from ..sim.session import Session, Tick
from ..sim.status import (
    MAX_PHASE_PER_STEP,
    AnswerCount,
    Health,
    diagnostic_values,
    mesh_phase_per_step,
    status_line,
)
from . import inputs, messages

DIAGNOSTICS_PERIOD = 1.0    # s of wall time between /diagnostics
STATUS_PERIOD = 5.0         # s of wall time between status log lines
LOCKSTEP_POLL = 0.1         # s of wall time between checks for shutdown while waiting
LOCKSTEP_RESEND = 0.5       # s of wall time before the last joint_states is sent again
LOCKSTEP_NOTICE = 3.0       # s of wall time without an answer before the node says so


class PacingThread:
    """The thread that runs a node's session in (real or scaled) time.

    Parameters
    ----------
    session, io
        The node's session and its publisher/recorder; this thread owns both once started.
    gate
        Lockstep's answer gate (thread-safe), answered by the executor thread.
    stop, wake
        Set to stop the thread; set to wake the pacer at once (a parameter change).
        ``stop`` is also set here when the thread fails.
    logger
        The node's logger.
    fqn
        The node's fully qualified name, for the diagnostics.
    refused
        The executor thread's count of inputs refused unread, per topic (read only).
    """

    def __init__(self, session: Session, io: RunIO, gate: AnswerGate, stop: threading.Event,
                 wake: threading.Event, logger: Any, fqn: str,
                 refused: Mapping[str, int]) -> None:
        self.session, self.io = session, io
        self._gate, self._stop, self._wake = gate, stop, wake
        self._log, self._fqn, self._refused = logger, fqn, refused
        self._warnings = RateLimiter(1.0)          # rejected inputs, per topic
        self._reversals = RateLimiter(STATUS_PERIOD)   # one reversal line per status period
        self._late = RateLimiter(STATUS_PERIOD)    # one late-answers warning per status period
        self.failed = False
        self._thread = threading.Thread(target=self._run, name='table_sim pacing', daemon=True)

    def start(self) -> None:
        self._thread.start()

    def join(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s for the thread to end; whether it did (or never ran)."""
        if self._thread.is_alive():
            self._thread.join(timeout=timeout)
        return not self._thread.is_alive()

    def _run(self) -> None:
        try:
            self._loop()
        except Exception:  # noqa: BLE001 - a bug: say so loudly, then let main() end the process
            self.failed = True
            self._log.fatal('pacing thread failed:\n' + traceback.format_exc())
            self._stop.set()

    def _loop(self) -> None:
        session, io = self.session, self.io
        s = session.settings
        pacer = Pacer(s.steps_per_publish * s.dt, s.real_time_factor)
        meter = FactorMeter()
        # Free-running, the session integrates tick k+1 right after it published tick k,
        # then sleeps to k+1's deadline: an answer to tick k that comes before tick k+1 is
        # published acts at tick k+2's first step, one that comes later a tick after that.
        # So it counts as in time when it came within that publish period (the gate's
        # window, polled just before the next publish; lockstep waits for it instead).
        answers = None if s.lockstep else AnswerCount(s.min_answer_rate)
        self._health = Health(s.real_time_factor, float('nan'), pacer.stats,
                              dict(session.rejected), dt=s.dt, lockstep=s.lockstep,
                              answers=answers)
        self._gate.expect()
        io.start(session)
        next_status = time.monotonic() + STATUS_PERIOD
        published = False         # a tick's joint_states went out (io.start's do not count)
        # Steps run, for duration: counted, since a faulted plant's time stands still
        ran = 0
        while not self._stop.is_set():
            if s.lockstep and not self._await_answer(meter):
                break
            tick = session.tick()
            ran += session.settings.steps_per_publish     # the tick's own length
            self._report(tick)
            if session.settings is not s:
                s = session.settings
                if pacer.period != s.steps_per_publish * s.dt or \
                        pacer.real_time_factor != s.real_time_factor:
                    pacer.restart(s.steps_per_publish * s.dt, s.real_time_factor)
                    self._health.requested_factor = s.real_time_factor
                if answers is not None:
                    answers.threshold = s.min_answer_rate
            if not pacer.wait(self._stop, self._wake):
                break
            if answers is not None and published:
                answers.tick(self._gate.wait(0.0))
            published = True
            self._gate.expect()
            io.tick(session, tick, lossless=s.real_time_factor == 0.0)   # no deadline
            if meter.elapsed() >= DIAGNOSTICS_PERIOD:
                self._health.achieved_factor = meter.update(tick.outputs.time)
                if answers is not None and answers.close():
                    self._warn_late(answers)
                self._publish_diagnostics()
                if time.monotonic() >= next_status:
                    next_status += STATUS_PERIOD
                    self._log.info(status_line(tick.outputs, self._health.achieved_factor,
                                               answers) + self._reversals_since())
            if 0.0 < s.duration <= (ran + 0.5) * s.dt:
                self._log.info(f'duration reached at t = {ran * s.dt:.6f} s of simulation '
                               f'(duration {s.duration:g} s): stopping')
                self._stop.set()            # main() closes the recording and exits 0
                break

    def _await_answer(self, meter: FactorMeter) -> bool:
        """Lockstep: wait for the controller's answer to the last outputs, re-sending
        them every LOCKSTEP_RESEND s and saying once after LOCKSTEP_NOTICE s that it
        waits. False when the node is stopping."""
        started = resent = time.monotonic()
        noticed = False
        while not self._gate.wait(LOCKSTEP_POLL):
            if self._stop.is_set():
                return False
            now = time.monotonic()
            if now - resent >= LOCKSTEP_RESEND:
                resent = now
                self.io.resend('joint_states', self.io.last_joint_states)
                self.io.resend_markers(self.session)
            if now - started >= LOCKSTEP_NOTICE and not noticed:
                noticed = True
                self._health.waiting = now - started
                self._log.warning(
                    f'lockstep: waiting for the controller since {now - started:.0f} s: '
                    f'no {ANSWERS} has answered joint_states at t = '
                    f'{self.session.last_outputs.time:.6f} s')
            if noticed and meter.elapsed() >= DIAGNOSTICS_PERIOD:
                self._health.waiting = now - started
                meter.update(self.session.last_outputs.time)
                self._publish_diagnostics()
        if noticed:
            self._health.waiting = 0.0
            self._log.info('lockstep: the controller answered; running')
        return True

    def _report(self, tick: Tick) -> None:
        """Log what a person should know about a tick (rate-limited where it repeats)."""
        if not (tick.applied or tick.rejected or tick.notices or tick.new_fault):
            return                          # most ticks: nothing happened to say
        if not self._health.commanded:
            self._health.commanded = any(isinstance(e, Command) for e in tick.applied)
        log = self._log
        for error in tick.rejected:
            emit, held = self._warnings.allow(error.topic)
            if emit:
                more = f' ({held} more rejected since the last warning)' if held else ''
                log.warning(inputs.excerpt(f'{error}{more}'))
        for notice in tick.notices:
            log.warning(notice)
        t = tick.start * self.session.plant.dt
        if tick.reversal and self._reversals.allow('reversal')[0]:
            log.info(f'reversal at t = {t:.6f} s: direction {tick.drive.direction:+d}, '
                     f'active path {tick.previous_path} -> {tick.outputs.active_path}')
        if any(isinstance(e, Reset) for e in tick.applied):
            log.info(f'reset to the preload equilibrium at t = {t:.6f} s')
        if tick.new_fault:
            log.error(f'{tick.fault}; simulation halted, publishing the last finite state; '
                      'call ~/reset to restart from equilibrium')

    def _warn_late(self, answers: AnswerCount) -> None:
        """Free-running: say (once per status period) that the controller's answers come
        too late for many ticks."""
        if self._late.allow('answers')[0]:
            self._log.warning(
                f'free-running: the controller answered {100.0 * answers.rate:.1f} % of the '
                f'last {answers.window} ticks within a publish period (below '
                f'min_answer_rate {answers.threshold:g}; {answers.missed} missed since start): '
                'a late answer acts a tick later, so the loop runs with a varying delay; '
                'run in lockstep (-p lockstep:=true), or lower real_time_factor or '
                'publish_rate')

    def _reversals_since(self) -> str:
        """The status line's count of reversals not logged one by one since the last
        status line (a controller holding the table at rest flips the path many times)."""
        held = self._reversals.drain('reversal')
        return f' | {held} more reversal{"s" * (held != 1)} since' if held else ''

    def _publish_diagnostics(self) -> None:
        health, session = self._health, self.session
        out = session.last_outputs
        health.rejected = dict(session.rejected)
        for topic, refused in dict(self._refused).items():    # the executor's count
            health.rejected[topic] = health.rejected.get(topic, 0) + refused
        health.fault = session.plant.fault
        health.command_timed_out = session.timed_out
        recorder = self.io.recorder
        if recorder is not None:
            health.recorder = (recorder.written, recorder.dropped)
            health.recorder_error = recorder.error
        params = session.plant.params
        level, text, values = diagnostic_values(params, out, health)
        msg = messages.diagnostics(f'{self._fqn}: simulation', 'screwgear_ros/table_sim',
                                   level, text, values, out.time_ns)
        self.io.send('diagnostics', out.time_ns, msg)
        phase_step = mesh_phase_per_step(params, out, health.dt)
        if phase_step > MAX_PHASE_PER_STEP and self._warnings.allow('mesh_phase')[0]:
            self._log.warning(
                f'mesh phase advances {phase_step:.3f} rad per step at t = {out.time:.3f} s '
                f'(> {MAX_PHASE_PER_STEP:.3f}): dt = {health.dt:g} s no longer resolves the '
                'tooth mesh at this speed; lower dt or the speed')


__all__ = ['DIAGNOSTICS_PERIOD', 'LOCKSTEP_NOTICE', 'LOCKSTEP_POLL', 'LOCKSTEP_RESEND',
           'STATUS_PERIOD', 'PacingThread']
