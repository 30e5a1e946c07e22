"""Typed, validated, immutable parameters of the double screw gear rotary table.

Every physical quantity of ``shared/spec/model.md`` lives in :class:`TableParams`
under its ROS parameter name (``shared/spec/interface.md``), in SI units. The
defaults are the paper's worked example (model.md section 6). Simulation settings
that are not physics (step, publish rate, pacing, recording) live in
:class:`SimSettings`. Both refuse an invalid value with a :class:`ParameterError`
that names the parameter, its value and the rule it breaks.

Beside this module: the paper's derived quantities (:mod:`~screwgear_ros.physics.quantities`),
RK4's stability limit (:mod:`~screwgear_ros.numerics.stability`), a whole validated set from a
mapping or a parameter file (:mod:`~screwgear_ros.sim.parameter_set`), and the documents
generated from these declarations (:mod:`~screwgear_ros.params.docs`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from ..interface import ANSWERS
from .declarations import ParameterError, declared, parameter, plain, validate
from .modes import MeshFormulation, MeshPhase, Mode
from .sensors import (
    MAX_SEED,
    SENSORS_INTRODUCED,
    SensorConfig,
    _encoder_counts,
    _measurement_delay,
    _position_noise,
    _velocity_filter_cutoff,
    _velocity_noise,
)

# Bounds of the physical parameters: wide around any real rotary table, narrow enough that
# every derived quantity (m_e, ω0, the stiffest eigenvalue, a disc's mass in the URDF)
# stays a normal double far from overflow and underflow.
INERTIA = (1e-6, 1e6)                 # kg·m²
INERTIA_WHY = 'a gear from a watch to a ship: every derived quantity stays finite'
RADIUS = (1e-4, 100.0)                # m
RADIUS_WHY = 'a gear from 0.1 mm to 100 m: every derived quantity stays finite'
TEETH = 100_000
STIFFNESS = 1e12                      # N/m
STIFFNESS_WHY = 'steel teeth are 1e8 … 1e10 N/m; RK4 then needs dt well inside its range'
DAMPING = 1e9                         # N·s/m, N·m·s/rad
TORQUE = 1e7                          # N·m
FREQUENCY = 1e6                       # rad/s
PHASE = 1e3                           # rad
STE = 1e-2                            # m: a transmission error of a centimetre is a broken gear
#: Most STE harmonics: the compiled model sums every harmonic in every RK4 stage of both
#: meshes, so the cost of a step grows with their count.
MAX_HARMONICS = 32
HARMONICS_WHY = ('each harmonic is summed in every RK4 stage of both meshes, so a step '
                 'costs in proportion; 32 describe any tooth profile error and keep the '
                 'default step within real time')


#: Pinion speed of the paper's example, 24 r/min, in rad/s.
PAPER_PINION_SPEED = 24.0 * 2.0 * math.pi / 60.0
#: Drive torque of the paper's example, N·m.
PAPER_DRIVE_TORQUE = 400.0


@dataclass(frozen=True)
class TableParams:
    """Physical parameters of the table, SI units, defaults = the paper's example.

    Radii are the tip radii m(z+2)/2 that reproduce the paper's m_e (model.md §6);
    k_m = ω0²·m_e = 1e7 N/m; c gives ζ = 0.05; ε_1 = fa·l = 1.5384 mm. Each field is
    the one declaration of its ROS parameter (:mod:`screwgear_ros.params.declarations`),
    history included: one added after the first recordings says ``introduced=`` (and
    ``before=`` when those recordings ran with another value). ``kernel=True`` fields are
    packed, in this order, for the compiled model.

    Frozen and hashable; an invalid value raises :class:`ParameterError` naming the
    parameter, its value and the rule (a range, or a rule across parameters).

    Examples
    --------
    >>> from screwgear_ros import TableParams
    >>> p = TableParams(backlash=1e-4)
    >>> p.backlash, p.replace(backlash=2e-4).backlash
    (0.0001, 0.0002)
    """

    inertia_pinion_1: float = parameter(3.255e-2, 'I1', 'kg·m²', 'inertia of pinion 1',
                                        low=INERTIA[0], high=INERTIA[1], why=INERTIA_WHY,
                                        kernel=True)
    inertia_table: float = parameter(46.101, 'I2', 'kg·m²', 'inertia of the table (large gear)',
                                     low=INERTIA[0], high=INERTIA[1], why=INERTIA_WHY,
                                     kernel=True)
    inertia_pinion_3: float = parameter(3.255e-2, 'I3', 'kg·m²', 'inertia of pinion 3',
                                        low=INERTIA[0], high=INERTIA[1], why=INERTIA_WHY,
                                        kernel=True)
    radius_pinion_1: float = parameter(0.078, 'r1', 'm', 'radius of pinion 1', low=RADIUS[0],
                                       high=RADIUS[1], why=RADIUS_WHY, kernel=True,
                                       note="tip radius m(z+2)/2, reproduces the paper's m_e")
    radius_table: float = parameter(0.582, 'r2', 'm', 'radius of the large gear',
                                    low=RADIUS[0], high=RADIUS[1], why=RADIUS_WHY, kernel=True)
    radius_pinion_3: float = parameter(0.078, 'r3', 'm', 'radius of pinion 3 (= r1 with a '
                                       'preload)', low=RADIUS[0], high=RADIUS[1], why=RADIUS_WHY,
                                       kernel=True)
    teeth_pinion_1: int = parameter(24, 'z1', '', 'teeth of pinion 1', low=1, high=TEETH,
                                    kernel=True)
    teeth_table: int = parameter(192, 'z2', '', 'teeth of the large gear', low=1,
                                  high=TEETH)
    teeth_pinion_3: int = parameter(24, 'z3', '', 'teeth of pinion 3', low=1, high=TEETH,
                                    kernel=True)
    mesh_stiffness_mean: float = parameter(1.0e7, 'k_m', 'N/m', 'mean mesh stiffness',
                                           low=1.0, high=STIFFNESS, why=STIFFNESS_WHY,
                                           note="ω0²·m_e of the paper")
    mesh_stiffness_amplitude: float = parameter(
        1.0e6, 'k_a', 'N/m', 'mesh stiffness fluctuation amplitude (< k_eff)', low=0.0,
        high=STIFFNESS, why=STIFFNESS_WHY, kernel=True, note="k_a' = 0.1")
    mesh_stiffness_phase: float = parameter(0.0, 'ϕ_k', 'rad', 'phase of the stiffness '
                                            'fluctuation', low=-PHASE, high=PHASE,
                                            kernel=True)
    preload_stiffness: float = parameter(0.0, 'k_p', 'N/m', 'stiffness added by the preload',
                                         low=0.0, high=STIFFNESS, why=STIFFNESS_WHY)
    mesh_damping: float = parameter(717.4777661364236, 'c', 'N·s/m', 'mesh damping', low=0.0,
                                    high=DAMPING, kernel=True, note='ζ = 0.05')
    ste_amplitudes: tuple[float, ...] = parameter(
        (1.5384e-3,), 'ε_n', 'm', 'static transmission error harmonics, n = index + 1',
        low=-STE, high=STE, max_items=MAX_HARMONICS, why=HARMONICS_WHY,
        note='ε_1 = fa·l = 1538.4 × 1 µm')
    ste_phases: tuple[float, ...] = parameter((0.0,), 'ϕ_n', 'rad', 'phases of the STE '
                                              'harmonics (a missing one is 0)',
                                              low=-PHASE, high=PHASE,
                                              max_items=MAX_HARMONICS, why=HARMONICS_WHY)
    backlash: float = parameter(75e-6, 'b', 'm', 'backlash half gap', low=0.0, high=STE,
                                kernel=True)
    preload_torque: float = parameter(
        350.0, 'T_p', 'N·m', 'preload bias torque on both pinions', low=0.0, high=TORQUE,
        kernel=True,
        note="min. 294 N·m holds an abrupt 400 N·m reversal at the paper's speed")
    thermal_coefficient: float = parameter(0.0, 'α', '1/K', 'thermal derating coefficient '
                                           'of k_m', low=-1.0, high=1.0)
    temperature_rise: float = parameter(0.0, 'ΔT', 'K', 'temperature rise', low=-1000.0,
                                        high=1000.0)
    torque_fluctuation_amplitude: float = parameter(0.0, 'T_v', 'N·m', 'drive torque '
                                                    'fluctuation amplitude', low=0.0,
                                                    high=TORQUE, kernel=True)
    torque_fluctuation_frequency: float = parameter(0.0, 'ω_v', 'rad/s', 'drive torque '
                                                    'fluctuation frequency', low=0.0,
                                                    high=FREQUENCY, kernel=True)
    table_damping: float = parameter(0.0, 'c_t', 'N·m·s/rad', 'viscous table bearing loss',
                                     low=0.0, high=DAMPING, kernel=True)
    table_coulomb_torque: float = parameter(
        0.0, 'τ_C2', 'N·m', 'Coulomb (sliding) friction torque of the table bearing '
        '(docs/model_notes.md §14)', low=0.0, high=TORQUE, kernel=True, introduced='0.2.0')
    table_static_torque: float = parameter(
        0.0, 'τ_S2', 'N·m', 'static (breakaway) friction torque of the table bearing, '
        '>= table_coulomb_torque; the table sticks while the torque holding it stays '
        'within it; 0 = no bearing friction', low=0.0, high=TORQUE, kernel=True,
        introduced='0.2.0')
    table_stribeck_speed: float = parameter(
        0.0, 'ω_S2', 'rad/s', 'Stribeck speed of the table bearing: the sliding friction '
        'falls from τ_S2 to τ_C2 as exp(-|ω|/ω_S2); 0 = at once', low=0.0, high=FREQUENCY,
        kernel=True, introduced='0.2.0')
    pinion_coulomb_torque: float = parameter(
        0.0, 'τ_Cp', 'N·m', 'Coulomb (sliding) friction torque of each pinion bearing',
        low=0.0, high=TORQUE, kernel=True, introduced='0.2.0')
    pinion_static_torque: float = parameter(
        0.0, 'τ_Sp', 'N·m', 'static (breakaway) friction torque of each pinion bearing, '
        '>= pinion_coulomb_torque; 0 = no bearing friction', low=0.0, high=TORQUE,
        kernel=True, introduced='0.2.0')
    pinion_stribeck_speed: float = parameter(
        0.0, 'ω_Sp', 'rad/s', 'Stribeck speed of each pinion bearing; 0 = at once',
        low=0.0, high=FREQUENCY, kernel=True, introduced='0.2.0')
    pinion_damping: float = parameter(0.0, 'c_p', 'N·m·s/rad', 'viscous loss of each pinion '
                                      'bearing', low=0.0, high=DAMPING, kernel=True,
                                      introduced='0.2.0')
    mesh_frequency: float = parameter(24 * PAPER_PINION_SPEED, 'ω_e', 'rad/s',
                                      'mesh frequency used when mesh_phase is time',
                                      low=0.0, high=FREQUENCY, kernel=True,
                                      note='24 teeth × 24 r/min')
    max_torque: float = parameter(400.0, 'T_max', 'N·m', 'largest accepted drive torque '
                                  'command', low=1e-3, high=TORQUE,
                                  note="the paper's drive torque")
    effort_deadband: float = parameter(
        1e-6, 'T_db', 'N·m', 'a cmd_effort or joint_commands effort of magnitude up to this is '
        'zero torque and keeps the drive direction (rounding noise of a controller at rest '
        'is no reversal)', low=0.0, high=10.0,
        note='2.5e-9 of max_torque, above the rounding noise of a PD law on rad-scale states',
        introduced='0.2.0', before=0.0)    # older runs: every nonzero effort drove
    direction_hysteresis: float = parameter(
        0.0, 'T_h', 'N·m', 'an effort against the drive direction in force reverses the drive '
        'only when its magnitude exceeds this; up to it, it is zero torque and keeps the '
        'direction (a dual-path drive switches paths with hysteresis, so sensor noise on a '
        'near-zero effort makes no path chatter)', low=0.0, high=TORQUE,
        note='0: every sign change outside the deadband is a reversal, as in the paper',
        introduced='0.2.0')
    drive_no_load_speed: float = parameter(
        8.0 * math.pi, 'ω_nl', 'rad/s', 'speed of the active pinion at which the drive '
        'torque line falls to zero (servo/DC characteristic); 0 = ideal torque source',
        low=1e-3, high=FREQUENCY, zero=True, kernel=True,
        note="240 r/min: terminal table speed 3.37 rad/s, mesh frequency 0.42·ω0",
        introduced='0.2.0', before=0.0)    # older runs: the ideal torque source
    drive_stall_torque: float = parameter(
        1600.0, 'T_s', 'N·m', 'torque of the drive line at standstill; a nonzero command '
        'delivers the smaller of the command and T_s·(1 − ω/ω_nl)', low=1e-3,
        high=TORQUE, kernel=True, note="400 N·m up to 180 r/min, 7.5× the paper's 24 r/min",
        introduced='0.2.0')
    drive_time_constant: float = parameter(
        0.0, 'τ_d', 's', "time constant of each drive's current loop: the torque at a pinion "
        'follows its drive\'s command as a first-order lag (the preload of the nuts does '
        'not); 0 = the command acts at once', low=1e-6, high=10.0, zero=True, kernel=True,
        why='a current loop of 160 kHz to 0.016 Hz bandwidth; RK4 needs dt below 2.78·τ_d',
        note='0: an ideal drive, the instant torque of the paper', introduced='0.2.0')
    cogging_amplitude: float = parameter(
        0.0, 'T_cog', 'N·m', "amplitude of each drive's output torque ripple "
        'T_cog·sin(n_cog·θ) at its pinion angle θ (cogging)', low=0.0, high=TORQUE,
        kernel=True, introduced='0.2.0')
    cogging_order: int = parameter(
        1, 'n_cog', '', 'harmonic of the pinion angle the cogging ripple has (periods per '
        'pinion revolution)', low=1, high=TEETH, kernel=True, introduced='0.2.0')
    # parameter() is a dataclasses.field() carrying its declaration (ruff sees a call)
    mode: Mode = parameter(Mode.ANTI_BACKLASH, '', '', 'both pinions under preload, or '  # noqa: RUF009
                           'pinion 1 alone with backlash', read_only=True)
    mesh_phase: MeshPhase = parameter(MeshPhase.ANGLE, '', '', 'what drives the mesh phase: '  # noqa: RUF009
                                      'the pinion angle (φ = z·θ) or time (φ = ω_e·t)',
                                      read_only=True)
    mesh_formulation: MeshFormulation = parameter(  # noqa: RUF009
        MeshFormulation.PAPER, '', '', "how the mesh acts on the bodies: the paper's "
        'equations (lever r) or forces from the mesh potential ½·K(φ)·f(δ)² (lever '
        'r − z·dε/dφ, plus ½·z·dK/dφ·f²)', read_only=True, introduced='0.2.0')

    def __post_init__(self) -> None:
        validate(self)
        if len(self.ste_amplitudes) != len(self.ste_phases):
            raise ParameterError(
                'ste_phases', list(self.ste_phases),
                f'needs one phase per STE harmonic ({len(self.ste_amplitudes)} amplitudes)')
        if (self.mode is Mode.ANTI_BACKLASH and self.preload_torque > 0.0
                and self.radius_pinion_3 != self.radius_pinion_1):
            raise ParameterError(
                'radius_pinion_3', self.radius_pinion_3,
                f'must equal radius_pinion_1 = {self.radius_pinion_1:g} m in anti_backlash mode '
                'with a preload: T1 = +T_p and T3 = -T_p balance at the table only when r1 = r3 '
                f'(else the preload alone turns the table with r2·T_p·(1/r1 - 1/r3))')
        for body in ('table', 'pinion'):
            coulomb = getattr(self, f'{body}_coulomb_torque')
            static = getattr(self, f'{body}_static_torque')
            if static < coulomb:
                raise ParameterError(
                    f'{body}_static_torque', static,
                    f'must be >= {body}_coulomb_torque = {coulomb:g} N·m (the breakaway '
                    'torque is where the sliding friction starts from)')
        derating = 1.0 - self.thermal_coefficient * self.temperature_rise
        if derating <= 0.0:
            raise ParameterError(
                'temperature_rise', self.temperature_rise,
                f'thermal derating 1 - α·ΔT = {derating:g} must stay > 0 '
                f'(α = {self.thermal_coefficient:g} 1/K)')
        k_eff = effective_stiffness(self)
        if self.mesh_stiffness_amplitude >= k_eff:
            raise ParameterError(
                'mesh_stiffness_amplitude', self.mesh_stiffness_amplitude,
                f'must be < k_eff = k_m(1 - α·ΔT) + k_p = {k_eff:g} N/m, '
                'or the mesh stiffness K = k_eff + k_a·cos(φ) could go negative')
        for pinion, radius in (('1', self.radius_pinion_1), ('3', self.radius_pinion_3)):
            slope = ste_slope(self, pinion)
            if slope >= radius:
                raise ParameterError(
                    'ste_amplitudes', list(self.ste_amplitudes),
                    f'in angle mesh phase the STE slope z{pinion}·Σ n·|ε_n| = {slope:g} m/rad '
                    f'must stay below r{pinion} = {radius:g} m, or the mesh of pinion {pinion} '
                    'would run backwards against its own rotation')

    def replace(self, **changes: Any) -> TableParams:
        """A validated copy with some parameters changed.

        Parameters
        ----------
        **changes
            Parameters by name.

        Returns
        -------
        TableParams
            The copy; :class:`ParameterError` if a changed value is refused.
        """
        return replace(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        """Parameter name → value as a ROS parameter (lists, enum strings).

        Returns
        -------
        dict
            What ``ros2 param dump`` would show, by name.
        """
        return {p.name: plain(getattr(self, p.name)) for p in declared(TableParams)}


@dataclass(frozen=True)
class SimSettings:
    """How the node runs the model: step, pacing, outputs, recording, sensors.

    Each field is the one declaration of its ROS parameter, as for :class:`TableParams`;
    an invalid value raises :class:`ParameterError` naming it.

    Examples
    --------
    >>> from screwgear_ros import SimSettings
    >>> SimSettings().dt
    5e-05
    >>> SimSettings(dt=-1.0)
    Traceback (most recent call last):
    ...
    screwgear_ros.params.declarations.ParameterError: parameter 'dt' = -1.0 refused: ...
    """

    dt: float = parameter(50e-6, 'dt', 's', 'RK4 integration step', low=1e-7, high=1e-2,
                          read_only=True)
    contact_location: bool = parameter(
        True, '', '', 'locate each change of mesh contact or of the drive line piece inside '
        'a step and split the step there (fourth order through backlash impacts); false = '
        'plain fixed-step RK4',
        read_only=True, introduced='0.2.0', before=False)   # older runs: plain RK4
    publish_rate: float = parameter(1000.0, '', 'Hz', 'output rate; 1/publish_rate must be a '
                                    'whole number of steps dt', low=1.0, high=1e6,
                                    why='at least one output a second of simulation time')
    real_time_factor: float = parameter(1.0, '', '', 'simulation time / wall time; 0 = as '
                                        'fast as possible', low=1e-2, high=1e3,
                                        zero=True, why='below 1/100 of real time the '
                                        'outputs of a 1 Hz node would come minutes apart')
    command_timeout: float = parameter(
        1.0, '', 's', 'simulation time without an accepted command after which the drive '
        'torque and the load go to zero; 0 = off', low=1e-3, high=1e6, zero=True,
        introduced='0.2.0', before=0.0)    # older runs: no timeout
    record: str = parameter('', '', '', 'rosbag2 (MCAP) directory to record this run to; '
                            'empty = off', read_only=True)
    publish_clock: bool = parameter(True, '', '', 'publish simulation time on /clock',
                                    read_only=True)
    lockstep: bool = parameter(False, '', '', 'integrate the next tick only after the '
                               f"controller's answer ({ANSWERS}) to the last joint_states",
                               read_only=True, introduced='0.2.0')
    duration: float = parameter(
        0.0, '', 's', 'simulation time at which the node stops by itself, as after Ctrl-C '
        '(the tick that reaches it is published and recorded, the recording closed, exit '
        '0); 0 = run until stopped', low=1e-6, high=1e9, zero=True,
        why='from one step to 30 years of simulation time',
        introduced='0.2.0', before=0.0)    # older runs: until stopped
    min_answer_rate: float = parameter(
        0.9, '', '', 'free-running: warn when, while a controller answers, a smaller share '
        'of ticks gets its answer (a cmd_effort after the last joint_states; ros2_control\'s '
        'joint_commands follow its own clock) within one publish period (a later one acts a '
        'tick later); '
        '0 = never warn', low=0.0, high=1.0, why='a share of the ticks',
        introduced='0.2.0', before=0.0)    # older runs: no count, no warning
    joint_names: tuple[str, ...] = parameter(('pinion_1', 'table', 'pinion_3'), '', '',
                                             'joint_states names of pinion 1, table, pinion 3; '
                                             'fixed for a run: a recording and the tools that '
                                             'read it know its joints by one set of names',
                                             read_only=True)
    encoder_counts_pinion_1: int = _encoder_counts('pinion 1', '1')
    position_noise_pinion_1: float = _position_noise('pinion 1', '1')
    velocity_noise_pinion_1: float = _velocity_noise('pinion 1', '1')
    measurement_delay_pinion_1: int = _measurement_delay('pinion 1', '1')
    velocity_filter_cutoff_pinion_1: float = _velocity_filter_cutoff('pinion 1', '1')
    encoder_counts_table: int = _encoder_counts('the table', '2')
    position_noise_table: float = _position_noise('the table', '2')
    velocity_noise_table: float = _velocity_noise('the table', '2')
    measurement_delay_table: int = _measurement_delay('the table', '2')
    velocity_filter_cutoff_table: float = _velocity_filter_cutoff('the table', '2')
    encoder_counts_pinion_3: int = _encoder_counts('pinion 3', '3')
    position_noise_pinion_3: float = _position_noise('pinion 3', '3')
    velocity_noise_pinion_3: float = _velocity_noise('pinion 3', '3')
    measurement_delay_pinion_3: int = _measurement_delay('pinion 3', '3')
    velocity_filter_cutoff_pinion_3: float = _velocity_filter_cutoff('pinion 3', '3')
    sensor_seed: int = parameter(
        0, '', '', 'seed of the sensor noise: the noise of a sample is a function of the '
        'seed, the joint and the sample\'s integration step only (screwgear_ros/physics/sensors.py), '
        'so a replay and check_run reproduce it', low=0, high=MAX_SEED,
        read_only=True, introduced=SENSORS_INTRODUCED)

    def __post_init__(self) -> None:
        validate(self)
        ratio = 1.0 / (self.publish_rate * self.dt)
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6 * ratio:
            raise ParameterError(
                'publish_rate', self.publish_rate,
                f'the publish period 1/{self.publish_rate:g} s must be a whole number '
                f'(>= 1) of integration steps dt = {self.dt:g} s')
        names = self.joint_names
        if len(names) != 3 or len(set(names)) != 3 or not all(names):
            raise ParameterError('joint_names', list(names),
                                 'must be three distinct, non-empty names '
                                 '(pinion 1, table, pinion 3)')

    @property
    def sensors(self) -> SensorConfig:
        """The joint sensors these settings declare (:mod:`screwgear_ros.physics.sensors`)."""
        return SensorConfig.of(self)

    @property
    def steps_per_publish(self) -> int:
        """Integration steps per publish period."""
        return round(1.0 / (self.publish_rate * self.dt))

    def as_dict(self) -> dict[str, Any]:
        """Setting name → value as a ROS parameter (lists, enum strings).

        Returns
        -------
        dict
            What ``ros2 param dump`` would show, by name.
        """
        return {p.name: plain(getattr(self, p.name)) for p in declared(SimSettings)}


# ------------------------------------------------ quantities the validation needs

def effective_stiffness(p: TableParams) -> float:
    """k_eff = k_m·(1 − α·ΔT) + k_p, N/m (thermal derating plus preload stiffness)."""
    return (p.mesh_stiffness_mean * (1.0 - p.thermal_coefficient * p.temperature_rise)
            + p.preload_stiffness)


def ste_slope(p: TableParams, pinion: str) -> float:
    """Largest |dε/dθ| of pinion '1' or '3', m/rad: z·Σ n·|ε_n| in `angle` phase, else 0.

    In `angle` phase δ̇ = (r − z·ε'(φ))·θ̇ − r2·θ̇2, so the pinion's lever on its mesh
    ranges over r ± this slope.
    """
    if p.mesh_phase is not MeshPhase.ANGLE:
        return 0.0
    teeth = p.teeth_pinion_1 if pinion == '1' else p.teeth_pinion_3
    return teeth * sum((n + 1) * abs(a) for n, a in enumerate(p.ste_amplitudes))


__all__ = [
    'PAPER_DRIVE_TORQUE',
    'PAPER_PINION_SPEED',
    'MeshFormulation',
    'MeshPhase',
    'Mode',
    'ParameterError',
    'SimSettings',
    'TableParams',
    'effective_stiffness',
    'ste_slope',
]
