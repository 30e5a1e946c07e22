"""What the table's encoders measure: the exact joint state in, joint_states out.

Each joint (pinion 1, table, pinion 3) has its own sensor (settings
``encoder_counts_*``, ``position_noise_*``, ``velocity_noise_*``, ``measurement_delay_*``,
``velocity_filter_cutoff_*``; one ``sensor_seed``). At every published sample (the outputs
of a tick, at integration step ``s``) the sensor of a joint with exact angle θ and speed ω
computes, in this order:

1. the read angle a = θ + σ_θ·z₁ (white noise, z₁ standard normal);
2. with N counts per revolution, the count n = ⌊a·N/2π⌋ (an incremental encoder
   reports the whole increments passed) and the position n·2π/N; with N = 0 (ideal)
   the position a itself;
3. the raw speed: with N > 0 as a drive computes it, the backward difference of the
   quantised positions of this sample and the sensor's previous one over the time
   between them ((s − s_prev)·dt), 0 at the first sample of a chain (a drive that has
   just started reports zero speed); with N = 0 the exact ω (an ideal tachometer); then
   + σ_ω·z₂;
4. with a cutoff f_c > 0, the first-order low-pass y = y_prev + α·(v − y_prev),
   α = 1 − exp(−2π·f_c·Δt) over the same Δt (the exact discretisation of
   τ·ẏ + y = v, τ = 1/(2π·f_c), for a v held over the interval), y = v at the first
   sample of a chain; f_c = 0: y = v;
5. a delay of k ticks: what is published at sample i is what steps 1–4 made at
   sample i − k (at the first k samples of a chain: what they made at its first).

The effort is not measured: it is the exact applied torque. A joint whose parameters are
all 0 publishes θ and ω untouched, so with every sensor ideal the measured joint_states
are the exact ones, bit for bit.

**Noise, reproducibly.** (z₁, z₂) of joint j at step s is a pure function of
(``sensor_seed``, s, j). Philox4×64-10 (NumPy's bit generator, counter-based: block c
of its stream is a fixed function of the key and c, integer arithmetic only) keyed by the
seed is one stream of 64-bit words; step s owns words 8s … 8s+7 (blocks 2s and 2s+1,
reached by setting the counter, never by drawing up to them) and uses the first six, two
per joint. The words of ``NOISE_BLOCK`` consecutive steps are drawn in one call and kept,
which gives the same words as drawing each step's own. Each word is made a uniform
u = (⌊w/2¹¹⌋ + ½)·2⁻⁵³ ∈ (0, 1) (exact in double), and the pair a Box–Muller normal
pair (√(−2 ln u₁)·cos 2πu₂, √(−2 ln u₁)·sin 2πu₂) computed with Python's scalar
``math`` (the C library, one value at a time: never NumPy's vector loops, which pick
code per CPU). Nothing depends on what was drawn before, on how many
ticks ran, on a restart of the process or on where a replay began: the noise of a sample
is that of its step, the integer the bag's log time records. So a replay, ``check_run``
and a process on another CPU reproduce it bit for bit, as they reproduce the kernel's
own sin and cos from the same C library.

**State.** A :class:`SensorChain` keeps, per joint, the previous read angle (step 3),
the filter output (step 4) and the delay line (step 5). :meth:`SensorChain.restart`
(a session's reset) starts a new chain: a reset moves the table without the encoder
turning, so a difference or a filter across it would report a speed the table never
had; the chain starts again at the first sample after the reset, as at the start of a
run. :meth:`SensorChain.configure` (a parameter change: the node makes the sensor
parameters read-only, so only an in-process session or a recorded parameter change
brings one) keeps the state and applies the new parameters from the next sample on: a
new N quantises the kept read angle afresh (no jump in the difference), a longer delay
holds the oldest value it has until its line fills.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..params.sensors import JOINTS, MAX_DELAY, MAX_SEED, JointSensor, SensorConfig

#: Steps whose noise words are drawn in one call (32 768 words, 256 KiB).
NOISE_BLOCK = 4096
_TWO_PI = 2.0 * math.pi
_UNIT = 2.0 ** -53
_WORD = 2 ** 64 - 1


class NoiseSource:
    """The standard normal pairs of (seed, step), three joints at a time (module
    docstring): the words of ``NOISE_BLOCK`` steps from the first one asked for, drawn
    again from wherever a step outside them is asked for. The counter set, not the
    history, fixes what the generator gives."""

    def __init__(self, seed: int) -> None:
        self.seed = int(seed)
        self._bits = np.random.Philox(key=self.seed)
        state = self._bits.state
        self._key = state['state']['key']
        self._buffer = state['buffer']
        self._first = -1                 # the step of self._words[0] (-1: none drawn)
        self._words = np.empty((0, 8), dtype=np.uint64)

    def _draw(self, step: int) -> None:
        block = 2 * step                 # blocks 2s and 2s + 1 are step s's
        counter = np.array([block & _WORD, block >> 64, 0, 0], dtype=np.uint64)
        self._bits.state = {'bit_generator': 'Philox',
                            'state': {'counter': counter, 'key': self._key},
                            'buffer': self._buffer, 'buffer_pos': 4, 'has_uint32': 0,
                            'uinteger': 0}
        self._words = self._bits.random_raw(8 * NOISE_BLOCK).reshape(NOISE_BLOCK, 8)
        self._first = step

    def pairs(self, step: int) -> list[tuple[float, float]]:
        """(z₁, z₂) of each joint at ``step`` (>= 0)."""
        k = step - self._first
        if self._first < 0 or not 0 <= k < NOISE_BLOCK:
            self._draw(step)
            k = 0
        words = self._words[k, :2 * len(JOINTS)].tolist()
        out = []
        for k in range(0, len(words), 2):
            u1 = ((words[k] >> 11) + 0.5) * _UNIT
            u2 = ((words[k + 1] >> 11) + 0.5) * _UNIT
            radius = math.sqrt(-2.0 * math.log(u1))
            angle = _TWO_PI * u2
            out.append((radius * math.cos(angle), radius * math.sin(angle)))
        return out


class _Joint:
    """One joint's chain state: previous step and read angle, filter output, delay line."""

    __slots__ = (
        'alpha',
        'angle',
        'filtered',
        'increment',
        'line',
        'per_rad',
        'sensor',
        'step',
    )

    def __init__(self, sensor: JointSensor) -> None:
        self.sensor = sensor
        self.step: int | None = None
        self.angle = 0.0
        self.filtered = 0.0
        self.line: deque[tuple[float, float]] = deque(maxlen=sensor.delay + 1)
        self.alpha: dict[int, float] = {}       # filter α by steps between samples
        self._counting(sensor)

    def _counting(self, sensor: JointSensor) -> None:
        """Counts per radian and radians per count, once per sensor, not per sample."""
        self.per_rad = sensor.counts / _TWO_PI if sensor.counts else 0.0
        self.increment = _TWO_PI / sensor.counts if sensor.counts else 0.0

    def use(self, sensor: JointSensor) -> None:
        if sensor.delay != self.sensor.delay:
            self.line = deque(self.line, maxlen=sensor.delay + 1)
        if sensor.cutoff != self.sensor.cutoff:
            self.alpha = {}
        self.sensor = sensor
        self._counting(sensor)

    def measure(self, step: int, dt: float, theta: float, omega: float,
                noise: tuple[float, float] | None) -> tuple[float, float]:
        s = self.sensor
        angle = (theta + s.position_noise * noise[0]
                 if s.position_noise and noise is not None else theta)
        if s.counts:
            per_rad, increment = self.per_rad, self.increment
            position = math.floor(angle * per_rad) * increment
            if self.step is None:
                speed = 0.0
            else:
                previous = math.floor(self.angle * per_rad) * increment
                speed = (position - previous) / ((step - self.step) * dt)
        else:
            position, speed = angle, omega
        if s.velocity_noise and noise is not None:
            speed = speed + s.velocity_noise * noise[1]
        if s.cutoff and self.step is not None:
            gap = step - self.step
            alpha = self.alpha.get(gap)
            if alpha is None:
                alpha = self.alpha[gap] = -math.expm1(-_TWO_PI * s.cutoff * gap * dt)
            speed = self.filtered + alpha * (speed - self.filtered)
        self.step, self.angle, self.filtered = step, angle, speed
        line = self.line
        line.append((position, speed))
        return line[0]


class SensorChain:
    """The sensors of a run, sample by sample (module docstring). ``dt``: the
    integration step, s (samples are told their step)."""

    def __init__(self, config: SensorConfig, dt: float) -> None:
        self.dt = float(dt)
        self.config = config
        self._joints = [_Joint(j) for j in config.joints]
        self._noise: NoiseSource | None = None
        self.configure(config)

    @property
    def ideal(self) -> bool:
        return self._ideal

    def configure(self, config: SensorConfig) -> None:
        """Use ``config`` from the next sample on, keeping the chain's state."""
        self.config = config
        for joint, sensor in zip(self._joints, config.joints, strict=True):
            joint.use(sensor)
        self._ideal = config.ideal
        if not config.noisy:
            self._noise = None
        elif self._noise is None or self._noise.seed != config.seed:
            self._noise = NoiseSource(config.seed)

    def restart(self) -> None:
        """Start a new chain at the next sample (a reset)."""
        self._joints = [_Joint(j) for j in self.config.joints]

    def measure_values(self, step: int, position: Sequence[float], velocity: Sequence[float]
                       ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """Measured (positions, velocities) of the exact ones at ``step``."""
        if self._ideal:
            return tuple(position), tuple(velocity)     # type: ignore[return-value]
        pairs = self._noise.pairs(step) if self._noise is not None else (None,) * 3
        dt = self.dt
        (p1, v1), (p2, v2), (p3, v3) = [
            joint.measure(step, dt, theta, omega, noise)
            for joint, theta, omega, noise in zip(self._joints, position, velocity, pairs,
                                                  strict=True)]
        return (p1, p2, p3), (v1, v2, v3)

    def measure(self, outputs: Any) -> Any:
        """The :class:`~screwgear_ros.sim.plant.Outputs` joint_states publishes for the exact
        ``outputs``: ``outputs`` itself when every sensor is ideal, else a copy with the
        measured positions and velocities."""
        if self._ideal:
            return outputs
        position, velocity = self.measure_values(outputs.step, outputs.position,
                                                 outputs.velocity)
        return type(outputs)(outputs.time, outputs.time_ns, outputs.step, position, velocity,
                             outputs.effort, outputs.delta, outputs.delta_rate,
                             outputs.mesh_force, outputs.active_path)


__all__ = [
    'JOINTS',
    'MAX_DELAY',
    'MAX_SEED',
    'NOISE_BLOCK',
    'JointSensor',
    'NoiseSource',
    'SensorChain',
    'SensorConfig',
]
