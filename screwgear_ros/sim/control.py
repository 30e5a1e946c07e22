"""The demo controller's law: a PID position loop on the table angle, with no ROS.

:class:`DemoLaw` is the pure control law that ``demo_controller`` (the rclpy node) runs on
each new joint state, and that :class:`DemoController` runs on each
:class:`~screwgear_ros.inprocess.simulation.Observation` of an in-process
:class:`~screwgear_ros.inprocess.simulation.Simulation`: one law, two transports.

The target steps through ``targets`` (rad), holding each for ``dwell`` s of simulation
time from the first joint state answered. Proportional and derivative gains place the
closed-loop poles of the paper's table (pure inertia about 49.7 kg·m² at the table, gear
ratio r2/r1 = 7.46) near ω_n = 20 rad/s, critically damped (Kp = I·ω_n²/7.46, Kd =
2ζω_n·I/7.46 with ζ = 1).

Each drive path pushes one way only (table_sim's effort: the sign picks the path, the
magnitude is its torque ≥ 0), and the table is a free inertia once the torque is 0. So a
step accelerates on one path and brakes on the other, and the braking path then brings
the table onto the target from the near side: whenever the wanted torque turns the
other way, the torque is 0 and the table creeps on, braked again as soon as it is too
fast (the PD law's line Kp·error = Kd·speed). Critical damping makes that approach free
of overshoot, so the braking path stays in force through the hold and is the one the
next step back starts on: one path switch per target reversal. A direction change needs
the wanted torque to exceed ``hysteresis`` the other way, and none happens while the
table holds its target (``|error| <= hold_error`` and ``|speed| <= hold_speed``): the
torque is then 0 and the effort a zero signed like the direction in force (a zero effort
keeps table_sim's direction). The integral acts only within ``integral_zone`` of the
target, on an error the path in force pushes against (a load it holds), never deeper into
its torque limit, and unwinds (never past zero) once the table is past the target; a path
switch clears it (it was the other path's torque). Integrating
an error the path in force cannot act on would only wind up and overshoot the target.

Time is taken from integer nanosecond stamps, as the node's joint_states carry them, so
the law gives the same bits over DDS and in-process.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from typing import Any

from .simtime import sim_time_ns

#: s: a longer gap between two joint states (lost samples) is not integrated.
MAX_GAP = 0.01
#: ns of simulation time after which an unchanged setpoint is sent again: a node or
#: recorder that came late gets it within that (a changed one is sent at once).
SETPOINT_REPEAT = 1_000_000_000
#: Index in joint_states of the table joint, the one the ``setpoint`` topic is about.
TABLE_JOINT = 1


class SetpointNotes:
    """When a controller sends its setpoint (table_sim's ``setpoint`` topic, only
    recorded): at its first answer, whenever the value changes, and unchanged every
    ``SETPOINT_REPEAT`` of simulation time; not with every answer, which would double
    the node's per-tick input work for a value that mostly stands still."""

    def __init__(self) -> None:
        self.restart()

    def restart(self) -> None:
        self.value: float | None = None
        self.stamp = 0

    def due(self, stamp: int, value: float) -> bool:
        """Whether to send ``value`` with the answer to the joint state stamped
        ``stamp`` (ns); True notes it as sent."""
        if value == self.value and 0 <= stamp - self.stamp < SETPOINT_REPEAT:
            return False
        self.value, self.stamp = value, stamp
        return True


@dataclass(frozen=True)
class DemoGains:
    """The demo law's parameters (the demo_controller node's ROS parameters)."""

    joint: str = 'table'                  # joint_states name of the controlled joint
    targets: tuple[float, ...] = (0.05, -0.05)   # rad, in turn
    dwell: float = 1.5                    # s of simulation time per target
    kp: float = 2665.0                    # N·m/rad
    ki: float = 8000.0                    # N·m/(rad·s)
    kd: float = 266.5                     # N·m·s/rad
    max_torque: float = 300.0             # N·m
    hysteresis: float = 1.0               # N·m
    integral_zone: float = 0.002          # rad
    hold_error: float = 0.0005            # rad: |target − angle| of a table holding its target
    hold_speed: float = 0.01              # rad/s: |speed| of a table holding its target

    def __post_init__(self) -> None:
        object.__setattr__(self, 'targets', tuple(float(v) for v in self.targets))
        if not self.targets:
            raise ValueError('demo controller: targets must hold at least one angle')
        for name in ('dwell', 'kp', 'ki', 'kd', 'max_torque', 'hysteresis', 'integral_zone',
                     'hold_error', 'hold_speed'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value < 0.0:
                raise ValueError(f'demo controller: {name} must be a finite number >= 0, '
                                 f'got {value!r}')
            object.__setattr__(self, name, float(value))
        if self.dwell <= 0.0:
            raise ValueError(f'demo controller: dwell must be > 0, got {self.dwell!r}')

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


class DemoLaw:
    """The PID law with its state (module docstring); :meth:`answer` one joint state."""

    def __init__(self, gains: DemoGains | None = None,
                 setpoint: Callable[[float], float] | None = None) -> None:
        self.gains = gains or DemoGains()
        self.setpoint = setpoint     # t (s) → target (rad) instead of targets and dwell
        self.restart()

    def restart(self) -> None:
        """Forget the run: the profile starts again at the next joint state."""
        self.t0: int | None = None           # ns: stamp of the first joint state answered
        self.last_stamp: int | None = None   # ns: stamp of the last one answered
        self.integral = 0.0
        self.direction = 0                   # 0 until a wanted torque other than 0 sets one

    def target(self, t: float) -> float:
        """Target angle, rad, at simulation time t (s) since the first joint state."""
        if self.setpoint is not None:
            return self.setpoint(t)
        targets = self.gains.targets
        return targets[int(t // self.gains.dwell) % len(targets)]

    def control(self, t: float, gap: float, angle: float, speed: float) -> float:
        """One PID step at t (s since the first joint state; ``gap`` s since the last):
        the signed effort, N·m (a signed zero while the torque is 0)."""
        g = self.gains
        error = self.target(t) - angle
        holding = abs(error) <= g.hold_error and abs(speed) <= g.hold_speed
        wanted = g.kp * error + g.ki * self.integral - g.kd * speed
        if self.direction == 0:
            if wanted != 0.0:
                self.direction = 1 if wanted > 0.0 else -1
        elif wanted * self.direction < -g.hysteresis and not holding:
            self.direction = -self.direction
            self.integral = 0.0              # it was torque of the other path
        drive = wanted * self.direction      # > 0: the path in force can give it
        # conditional integration: near the target, only an error the path in force
        # pushes against (a load it holds), and never deeper into its torque limit
        if abs(error) < g.integral_zone and 0.0 < gap <= MAX_GAP:
            if error * self.direction > 0.0 and drive < g.max_torque:
                self.integral += error * gap
            elif self.integral * self.direction > 0.0:
                # past the target: unwind what the path in force was given, never beyond
                # zero (it cannot pull back); a kept integral would push the table on
                # through a bearing's breakaway torque, away from the target
                self.integral += error * gap
                if self.integral * self.direction < 0.0:
                    self.integral = 0.0
            if g.ki > 0.0:
                limit = 0.5 * g.max_torque / g.ki
                self.integral = min(limit, max(-limit, self.integral))
        torque = min(g.max_torque, max(0.0, drive))
        return math.copysign(torque, self.direction or 1)

    def answer(self, stamp: int, angle: float, speed: float) -> tuple[float, float]:
        """The effort for a new joint state stamped ``stamp`` (ns, later than the last
        one answered), and the time t (s since the first) it was computed at."""
        if self.t0 is None or self.last_stamp is None:
            self.t0 = self.last_stamp = stamp
        t, gap = (stamp - self.t0) * 1e-9, (stamp - self.last_stamp) * 1e-9
        self.last_stamp = stamp
        return self.control(t, gap, angle, speed), t

    def stop_effort(self) -> float:
        """A zero effort signed like the direction in force (torque 0, direction kept)."""
        return math.copysign(0.0, self.direction or 1)


class DemoController:
    """The demo law as a :meth:`Simulation.run <screwgear_ros.inprocess.simulation.Simulation.run>`
    controller: ``controller(observation) -> effort``.

    The stamps are the node's (:func:`~screwgear_ros.sim.simtime.sim_time_ns` of the
    observation's step), so a run gives the bits a lockstep run of table_sim with
    demo_controller gives. A new run (an observation at an earlier step than the last)
    restarts the profile; a stamp answered already gets None (no new command).

    Parameters
    ----------
    gains : DemoGains, optional
        The law's gains, profile and hold band; default ``DemoGains(**values)``.
    dt : float
        The simulation's step, s (``SimSettings.dt``), to stamp observations as the node.
    joint_names : sequence of str
        The joint_states names, to find the controlled joint (``gains.joint``).
    setpoint : callable, optional
        ``setpoint(t) -> target angle`` (rad, t in s) instead of the demo's profile.
    **values
        Fields of :class:`DemoGains` when ``gains`` is not given.

    Raises
    ------
    ValueError
        ``gains.joint`` is not one of ``joint_names``.

    Examples
    --------
    >>> from screwgear_ros import DemoController, Simulation
    >>> sim = Simulation()
    >>> run = sim.run(DemoController(dt=sim.settings.dt), 0.01)
    >>> len(run) > 0
    True
    """

    def __init__(self, gains: DemoGains | None = None, *, dt: float = 50e-6,
                 joint_names: Sequence[str] = ('pinion_1', 'table', 'pinion_3'),
                 setpoint: Callable[[float], float] | None = None, **values: Any) -> None:
        gains = gains or DemoGains(**values)
        if gains.joint not in joint_names:
            raise ValueError(f'demo controller: joint {gains.joint!r} is not one of the '
                             f'joint_states names {list(joint_names)}')
        self.law = DemoLaw(gains, setpoint)
        self.dt = float(dt)
        self._index = list(joint_names).index(gains.joint)

    def __call__(self, observation: Any) -> float | None:
        stamp = sim_time_ns(observation.step, self.dt)
        last = self.law.last_stamp
        if last is not None and stamp <= last:
            if stamp == last:
                return None          # a stamp answered already (a faulted plant stands still)
            self.law.restart()
        i = self._index
        return self.law.answer(stamp, observation.position[i], observation.velocity[i])[0]


__all__ = [
    'MAX_GAP',
    'SETPOINT_REPEAT',
    'TABLE_JOINT',
    'DemoController',
    'DemoGains',
    'DemoLaw',
    'SetpointNotes',
]
