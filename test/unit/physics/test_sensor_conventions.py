"""The encoder conventions docs/model_notes.md §15 states for an independent
implementation, each on one sensor sample by sample (SensorChain), against the closed
form written out here: a count is floor(), not round(); the noise is the normal pair of
the sample's own step; the first delayed samples repeat the chain's first measurement;
the speed filter starts at its first input; the speed noise goes in before the filter."""

from __future__ import annotations

import math

from screwgear_ros.physics.sensors import JointSensor, NoiseSource, SensorChain, SensorConfig

DT = 1e-3
TABLE = 1        # joint index: pinion 1, table, pinion 3


def chain(sensor: JointSensor, seed: int = 0) -> SensorChain:
    return SensorChain(SensorConfig((sensor, sensor, sensor), seed), DT)


def table(c: SensorChain, step: int, theta: float, omega: float) -> tuple[float, float]:
    position, velocity = c.measure_values(step, (theta,) * 3, (omega,) * 3)
    return position[TABLE], velocity[TABLE]


def test_a_count_is_the_floor_of_the_angle_in_counts():
    increment = 2.0 * math.pi / 8
    c = chain(JointSensor(counts=8))
    assert table(c, 0, 0.9 * increment, 0.0)[0] == 0.0          # round() would give 1 count
    assert table(c, 1, -0.1 * increment, 0.0)[0] == -increment  # toward −∞, not toward 0
    assert table(c, 2, 2.0 * increment, 0.0)[0] == 2.0 * increment


def test_noise_is_the_normal_pair_of_the_samples_own_step():
    sigma_angle, sigma_speed, seed = 1e-3, 2e-2, 42
    c = chain(JointSensor(position_noise=sigma_angle, velocity_noise=sigma_speed), seed)
    pairs = NoiseSource(seed)
    for step in (7, 3, 5000):                  # any order: the step decides
        z1, z2 = pairs.pairs(step)[TABLE]
        assert table(c, step, 0.5, 2.0) == (0.5 + sigma_angle * z1, 2.0 + sigma_speed * z2)


def test_the_first_delayed_samples_repeat_the_first_measurement():
    c = chain(JointSensor(delay=2))
    published = [table(c, k, 0.1 * (k + 1), float(k))[0] for k in range(5)]
    assert published == [0.1, 0.1, 0.1, 0.2, 0.1 * 3]


def test_the_speed_filter_starts_at_its_first_input():
    c = chain(JointSensor(cutoff=100.0))
    assert table(c, 0, 0.0, 5.0)[1] == 5.0                      # not 0: no ramp from rest
    alpha = 1.0 - math.exp(-2.0 * math.pi * 100.0 * DT)
    assert math.isclose(table(c, 1, 0.0, 1.0)[1], 5.0 + alpha * (1.0 - 5.0), rel_tol=1e-14)


def test_the_speed_noise_goes_in_before_the_filter():
    sigma, seed, cutoff = 0.5, 3, 50.0
    c = chain(JointSensor(velocity_noise=sigma, cutoff=cutoff), seed)
    pairs = NoiseSource(seed)
    first = sigma * pairs.pairs(0)[TABLE][1]
    assert table(c, 0, 0.0, 0.0)[1] == first
    alpha = 1.0 - math.exp(-2.0 * math.pi * cutoff * DT)
    second = first + alpha * (sigma * pairs.pairs(1)[TABLE][1] - first)
    assert math.isclose(table(c, 1, 0.0, 0.0)[1], second, rel_tol=1e-12)
