"""The joint sensors a parameter set declares: per joint an encoder's counts, noise,
delay and speed filter, and the seed of the noise (what the sensors measure is
:mod:`screwgear_ros.physics.sensors`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .declarations import parameter

#: The joints in joint_states order, as the sensor parameters name them.
JOINTS = ('pinion_1', 'table', 'pinion_3')
#: Longest measurement delay, ticks: the delay line is kept per joint.
MAX_DELAY = 1000
#: Largest seed (the largest value of the node's integer parameter ranges).
MAX_SEED = 2 ** 31 - 1


@dataclass(frozen=True)
class JointSensor:
    """The sensor of one joint (see the module docstring)."""

    counts: int = 0                 # per revolution, 0 = ideal
    position_noise: float = 0.0     # σ_θ, rad
    velocity_noise: float = 0.0     # σ_ω, rad/s
    delay: int = 0                  # ticks
    cutoff: float = 0.0             # f_c, Hz, 0 = no filter

    @property
    def ideal(self) -> bool:
        return not (self.counts or self.position_noise or self.velocity_noise or self.delay
                    or self.cutoff)


@dataclass(frozen=True)
class SensorConfig:
    """The three joints' sensors and the seed of their noise."""

    joints: tuple[JointSensor, JointSensor, JointSensor] = (JointSensor(),) * 3
    seed: int = 0

    @classmethod
    def of(cls, settings: Any) -> SensorConfig:
        """The sensors a :class:`~screwgear_ros.params.table.SimSettings` declares."""
        first, second, third = (JointSensor(getattr(settings, f'encoder_counts_{j}'),
                                            getattr(settings, f'position_noise_{j}'),
                                            getattr(settings, f'velocity_noise_{j}'),
                                            getattr(settings, f'measurement_delay_{j}'),
                                            getattr(settings, f'velocity_filter_cutoff_{j}'))
                                for j in JOINTS)
        return cls((first, second, third), settings.sensor_seed)

    @property
    def ideal(self) -> bool:
        """Every joint ideal: the measured joint states are the exact ones."""
        return all(j.ideal for j in self.joints)

    @property
    def noisy(self) -> bool:
        return any(j.position_noise or j.velocity_noise for j in self.joints)


#: Most encoder counts per revolution (2^30: a 30-bit encoder resolves 5.9e-9 rad).
MAX_COUNTS = 2 ** 30


#: The version that added the sensor parameters (recordings before it measured ideally).
SENSORS_INTRODUCED = '0.2.0'


# One declaration per sensor quantity; each joint's fields below are made by these.
def _encoder_counts(joint: str, k: str) -> Any:
    return parameter(
        0, f'N{k}', 'counts/rev', f'encoder counts per revolution of {joint}: joint_states '
        'reports its angle in whole counts and its speed as their backward difference over '
        'the tick; 0 = ideal (the exact angle and speed)', low=1, high=MAX_COUNTS, zero=True,
        read_only=True, why='a 30-bit encoder, finer than any table encoder sold',
        introduced=SENSORS_INTRODUCED)


def _position_noise(joint: str, k: str) -> Any:
    return parameter(
        0.0, f'σ_θ{k}', 'rad', f'white noise (standard deviation) on the angle of {joint} '
        'before it is counted', low=0.0, high=1.0, read_only=True,
        introduced=SENSORS_INTRODUCED)


def _velocity_noise(joint: str, k: str) -> Any:
    return parameter(
        0.0, f'σ_ω{k}', 'rad/s', f'white noise (standard deviation) on the speed of {joint}',
        low=0.0, high=1e3, read_only=True, introduced=SENSORS_INTRODUCED)


def _measurement_delay(joint: str, k: str) -> Any:
    return parameter(
        0, f'k{k}', 'ticks', f'joint_states reports the angle and speed of {joint} this many '
        'publish ticks late', low=0, high=MAX_DELAY, read_only=True,
        why='the delay line is kept per joint', introduced=SENSORS_INTRODUCED)


def _velocity_filter_cutoff(joint: str, k: str) -> Any:
    return parameter(
        0.0, f'f_c{k}', 'Hz', 'cutoff of the first-order low-pass on the measured speed of '
        f'{joint} (α = 1 − exp(−2π·f_c·Δt) per sample); 0 = off', low=1e-3, high=1e6,
        zero=True, read_only=True, introduced=SENSORS_INTRODUCED)


__all__ = ['JOINTS', 'MAX_COUNTS', 'MAX_DELAY', 'MAX_SEED', 'SENSORS_INTRODUCED', 'JointSensor',
           'SensorConfig']
