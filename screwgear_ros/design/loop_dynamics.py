"""The sensor and drive dynamics a parameter file declares, added to a linear model
(:func:`with_dynamics`): what a controller's loop goes through besides the mechanics.

* **The drive lag** (``drive_time_constant`` τ_d > 0): each drive's current loop delivers
  its command through a first-order lag, the same τ_d for both, the preload not lagged
  (docs/model_notes.md). While the drive delivers its command (not on its torque–speed
  line) the delivered torque is that lag of the command alone, so one state
  ``drive_torque_delivered`` z, ż = (u − z)/τ_d, feeding the model's drive column, is
  exact: A' = [[A, B_u], [0, −1/τ_d]], B'_u = [0; 1/τ_d]. On the torque–speed line the
  command does nothing and the drive's speed feedback stays instant (said so).
* **The joint sensors** (``measurement_delay_*`` k, ``velocity_filter_cutoff_*`` f_c,
  ``encoder_counts_*`` N; physics/sensors.py) act once per published sample, h apart, so
  they are exact in discrete time, as the sampled-data loop sees the plant
  (:func:`~.margins.held_response`), factors of z = exp(jωh) on each output sample:
  the angle z^−k; the speed z^−k·F(z)·V(z) with the low-pass F(z) = α/(1 − (1 − α)z^−1),
  α = 1 − exp(−2π·f_c·h) (1 with f_c = 0), and V the speed the drive computes: with N > 0
  the backward difference of the angles, (1 − z^−1)/h on the angle row; with N = 0 the
  exact speed. Quantization and noise are not linear and are left out (a count of a
  26-bit encoder is 94 nrad). The transmission error is not measured: no factor.
  The continuous :meth:`~.linear_model.LinearModel.response` holds the drive lag only.

Examples
--------
>>> from screwgear_ros.params.table import SimSettings, TableParams
>>> from screwgear_ros.design.linearize import linearize
>>> params = TableParams().replace(drive_time_constant=1e-4)
>>> settings = SimSettings(measurement_delay_table=1)
>>> model = with_dynamics(linearize(params), params, settings)
>>> model.states[-1], model.sensors.joints[1].delay
('drive_torque_delivered', 1)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..params.sensors import JOINTS
from ..params.table import SimSettings, TableParams
from ..physics.drive import DrivePiece
from .linear_model import LAG_STATE, OUTPUTS, LinearModel

#: The joint (index in JOINTS) and quantity each output reads; None: not measured.
_MEASURED = {'pinion_1_angle': (0, 'angle'), 'table_angle': (1, 'angle'),
             'pinion_3_angle': (2, 'angle'), 'pinion_1_speed': (0, 'speed'),
             'table_speed': (1, 'speed'), 'pinion_3_speed': (2, 'speed'),
             'transmission_error': None}


@dataclass(frozen=True)
class JointSensorModel:
    """The linear part of one joint's sensor: its delay (ticks), its speed filter's
    cutoff (Hz, 0: none) and whether its speed is the difference of counted angles."""

    delay: int = 0
    cutoff: float = 0.0
    differenced: bool = False

    @property
    def ideal(self) -> bool:
        return not (self.delay or self.cutoff or self.differenced)


@dataclass(frozen=True)
class SensorModel:
    """The three joints' sensors (pinion 1, table, pinion 3), module docstring."""

    joints: tuple[JointSensorModel, JointSensorModel, JointSensorModel]

    @property
    def ideal(self) -> bool:
        return all(j.ideal for j in self.joints)

    def factors(self, frequency_hz: np.ndarray, h: float,
                outputs: tuple[str, ...] = OUTPUTS) -> np.ndarray:
        """The factor of each output's sample at each frequency, shape (outputs,
        frequencies); a differenced speed is returned as the factor of the angle's
        response (see :meth:`apply`)."""
        z = np.exp(2j * math.pi * np.atleast_1d(np.asarray(frequency_hz, float)) * h)
        out = np.ones((len(outputs), len(z)), dtype=complex)
        for i, name in enumerate(outputs):
            measured = _MEASURED.get(name)
            if measured is None:
                continue
            joint, quantity = measured
            sensor = self.joints[joint]
            factor = z ** -float(sensor.delay)
            if quantity == 'speed':
                if sensor.cutoff > 0.0:
                    alpha = 1.0 - math.exp(-2.0 * math.pi * sensor.cutoff * h)
                    factor = factor * alpha / (1.0 - (1.0 - alpha) / z)
                if sensor.differenced:
                    factor = factor * (1.0 - 1.0 / z) / h
            out[i] = factor
        return out

    def apply(self, response: np.ndarray, frequency_hz: np.ndarray, h: float,
              outputs: tuple[str, ...] = OUTPUTS) -> np.ndarray:
        """The sampled response (outputs, inputs, frequencies) as the sensors report it:
        each row times its factor; a differenced speed row is made from its joint's
        angle row (the drive differences the angles, not the speed)."""
        factors = self.factors(frequency_hz, h, outputs)
        out = np.array(response, dtype=complex)
        for i, name in enumerate(outputs):
            measured = _MEASURED.get(name)
            if measured is None:
                continue
            joint, quantity = measured
            source = response[i]
            if quantity == 'speed' and self.joints[joint].differenced:
                angle = ('pinion_1_angle', 'table_angle', 'pinion_3_angle')[joint]
                if angle not in outputs:
                    raise ValueError(f'{name} differences {angle}, which is not an output')
                source = response[outputs.index(angle)]
            out[i] = source * factors[i][None, :]
        return out


def declares_dynamics(params: TableParams, settings: SimSettings) -> bool:
    """Whether the parameters declare a drive lag or a sensor delay, speed filter or
    encoder (what :func:`with_dynamics` would add)."""
    return params.drive_time_constant > 0.0 or not sensor_model(settings).ideal


def sensor_model(settings: SimSettings) -> SensorModel:
    """The linear part of the joint sensors ``settings`` declare."""
    joints = tuple(JointSensorModel(int(getattr(settings, f'measurement_delay_{j}')),
                                    float(getattr(settings, f'velocity_filter_cutoff_{j}')),
                                    bool(getattr(settings, f'encoder_counts_{j}')))
                   for j in JOINTS)
    return SensorModel(joints)  # type: ignore[arg-type]


def with_dynamics(model: LinearModel, params: TableParams, settings: SimSettings,
                  ) -> LinearModel:
    """``model`` with the drive lag and the joint sensors ``params`` and ``settings``
    declare (module docstring), each named in :attr:`LinearModel.notes`.

    Parameters
    ----------
    model : LinearModel
        The mechanics (:func:`~.linearize.linearize`), six states.
    params, settings : TableParams, SimSettings
        The table and the simulation whose drive and sensors are added.

    Returns
    -------
    LinearModel
        Seven states with a drive lag, its ``sensors`` set when any sensor is not ideal.
    """
    notes = list(model.notes)
    a, b, states = model.a, model.b, model.states
    tau = params.drive_time_constant
    if tau > 0.0 and LAG_STATE not in states:
        if model.point.drive_piece == DrivePiece.COMMAND:
            n = a.shape[0]
            a = np.block([[a, b[:, :1]], [np.zeros((1, n)), np.full((1, 1), -1.0 / tau)]])
            b = np.vstack([b, np.zeros((1, b.shape[1]))])
            b[:, 0] = 0.0
            b[n, 0] = 1.0 / tau
            states = (*states, LAG_STATE)
            notes.append(f'drive lag: τ_d = {tau:.4g} s, the state {LAG_STATE} '
                         f'(a pole at {1.0 / (2.0 * math.pi * tau):.4g} Hz)')
        else:
            notes.append(f'drive lag: τ_d = {tau:.4g} s left out: the drive runs on its '
                         'torque–speed line, where the command does nothing and its speed '
                         'feedback is taken instant')
    sensors = sensor_model(settings)
    used: Any = None
    if not sensors.ideal:
        used = sensors
        for name, joint in zip(JOINTS, sensors.joints, strict=True):
            if not joint.ideal:
                notes.append(f'sensor {name}: delay {joint.delay} ticks, speed '
                             + (f'filtered at {joint.cutoff:g} Hz' if joint.cutoff
                                else 'unfiltered')
                             + (', the difference of counted angles' if joint.differenced
                                else ', exact'))
    c = np.hstack([model.c, np.zeros((model.c.shape[0], a.shape[0] - model.c.shape[1]))])
    return replace(model, a=a, b=b, c=c, states=states, sensors=used, notes=tuple(notes))


def loop_plant(params: TableParams, settings: SimSettings, torque: float, load: float,
               direction: int, mesh: str, dynamics: bool = True) -> LinearModel:
    """The linear plant a loop measurement compares with: the mechanics at the point,
    its bearing friction sliding in rotation or left out at rest
    (:mod:`.friction_state`: stuck bearings have no linear model), and with ``dynamics``
    the drive lag and sensors the parameters declare; each choice in ``notes``."""
    from .friction_state import FrictionUndefined, linearize_with_friction
    try:
        model, _, friction = linearize_with_friction(params, torque, load, direction, mesh)
    except FrictionUndefined:
        model, _, friction = linearize_with_friction(params, torque, load, direction, mesh,
                                                     ignore=True)
    model = replace(model, notes=(*model.notes, friction))
    return with_dynamics(model, params, settings) if dynamics else model


__all__ = ['JointSensorModel', 'SensorModel', 'declares_dynamics', 'loop_plant',
           'sensor_model', 'with_dynamics']
