"""The drive line of ``shared/spec/model.md``: the torque each drive applies to its pinion
per mode (preload, command, fluctuation), the drive's torque–speed line and its pieces,
and the current loops' lag. Compiled kernels on the packed model
(:mod:`.packed`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ..params.table import Mode
from .jit import kernel
from .packed import (
    MODE,
    MODE_CONVENTIONAL,
    TAU,
    TP,
    TS,
    TV,
    WNL,
    WV,
    Drive,
)


class DrivePiece(IntEnum):
    """Which piece of the drive's torque–speed line (the smaller of the command and
    T_s·(1 − ω/ω_nl), :func:`drive_piece`) delivers the torque: the delivered torque is smooth on each and kinks where the
    command meets the line, so the integrator locates that too."""

    COMMAND = 0           # the command itself (below the line, no command, ideal source)
    LINE = 1              # the line T_s·(1 − ω/ω_nl), below the command
    FROM_STATE = -1       # not a piece: picked from the speed


@kernel
def drive_piece(torque: float, speed: float, p: np.ndarray) -> DrivePiece:
    """The piece of the drive's torque–speed line that delivers command ``torque`` at
    the active pinion's ``speed`` (rad/s, positive in the sense it drives): the smaller of
    the command and T_s·(1 − ω/ω_nl), which falls to zero at the no-load speed ω_nl and
    brakes beyond it. A zero command is a drive switched off; ω_nl = 0: the command itself
    (ideal torque source)."""
    if p[WNL] <= 0.0 or torque <= 0.0:
        return DrivePiece.COMMAND
    return DrivePiece.COMMAND if torque <= p[TS] * (1.0 - speed / p[WNL]) else DrivePiece.LINE


@kernel
def drive_on(piece: DrivePiece, torque: float, speed: float, p: np.ndarray) -> float:
    """Drive torque delivered, N·m, on a given piece of the drive's line (:func:`drive_piece`)."""
    if piece == DrivePiece.LINE:
        return p[TS] * (1.0 - speed / p[WNL])
    return torque


@kernel
def active_speed(w1: float, w3: float, direction: float, p: np.ndarray) -> float:
    """Speed of the driving pinion in the sense it drives, rad/s: d·ω1 (`conventional`),
    ω1 (path 1) or −ω3 (path 3, `anti_backlash`)."""
    if p[MODE] == MODE_CONVENTIONAL:
        return direction * w1
    return w1 if direction > 0.0 else -w3


@kernel
def applied_torques(t: float, w1: float, w3: float, torque: float, direction: float,
                    p: np.ndarray) -> tuple[float, float]:
    """Torques (T1, T3) on pinions 1 and 3, N·m, with the drive's torque–speed line:
    :func:`drive_torques` of the torque the drive's line delivers (:func:`drive_piece`)."""
    return applied_torques_on(DrivePiece.FROM_STATE, t, w1, w3, torque, direction, p)[:2]


@kernel
def applied_torques_on(piece: DrivePiece, t: float, w1: float, w3: float, torque: float,
                       direction: float, p: np.ndarray) -> tuple[float, float, DrivePiece]:
    """:func:`applied_torques` with the drive on ``piece`` (DrivePiece.FROM_STATE: the
    piece the speed picks), and that piece."""
    speed = active_speed(w1, w3, direction, p)
    if piece == DrivePiece.FROM_STATE:
        piece = drive_piece(torque, speed, p)
    t1, t3 = drive_torques(t, drive_on(piece, torque, speed, p), direction, p)
    return t1, t3, piece


@kernel
def drive_torques(t: float, torque: float, direction: float,
                  p: np.ndarray) -> tuple[float, float]:
    """Torques (T1, T3) on pinions 1 and 3, N·m, for the commanded drive.

    The drive torque T + T_v·sin(ω_v·t) acts on the active pinion. `anti_backlash`:
    T1 = T_p (+ drive if d = +1), T3 = −T_p (− drive if d = −1). `conventional`:
    T1 = d·drive, T3 = 0.
    """
    drive = torque if p[TV] == 0.0 else torque + p[TV] * math.sin(p[WV] * t)
    if p[MODE] == MODE_CONVENTIONAL:
        return direction * drive, 0.0
    if direction > 0.0:
        return p[TP] + drive, -p[TP]
    return p[TP], -p[TP] - drive


@kernel
def drive_targets(piece: DrivePiece, w1: float, w3: float, torque: float, direction: float,
                  p: np.ndarray) -> tuple[float, float]:
    """What each drive's current loop is commanded (N·m, signed in the sense that drives
    the table forward, preload and fluctuation excluded): the torque the drive's line
    delivers on ``piece`` (:func:`drive_on`; a servo drive limits its torque reference by
    the speed) on the active pinion, 0 on the other."""
    delivered = drive_on(piece, torque, active_speed(w1, w3, direction, p), p)
    if p[MODE] == MODE_CONVENTIONAL:
        return direction * delivered, 0.0
    if direction > 0.0:
        return delivered, 0.0
    return 0.0, -delivered


@kernel
def lag_state(y: tuple) -> tuple[float, float]:
    """The drives' lagged torques L1, L3 (N·m) of state y: y[6], y[7], or 0 for a
    mechanical state alone (six entries; the length is known when the kernel compiles)."""
    if len(y) > 6:
        return y[6], y[7]
    return 0.0, 0.0


@kernel
def lag_rates(y: tuple, torque: float, direction: float, piece: DrivePiece,
              p: np.ndarray) -> tuple[float, float]:
    """dL1/dt, dL3/dt (N·m/s) of the lagged drive torques y[6], y[7]: (target − L)/τ_d
    toward :func:`drive_targets`; 0 with τ_d = 0 (no lag, the states unused)."""
    if p[TAU] == 0.0:
        return 0.0, 0.0
    m1, m3 = drive_targets(piece, y[3], y[5], torque, direction, p)
    lag1, lag3 = lag_state(y)
    return (m1 - lag1) / p[TAU], (m3 - lag3) / p[TAU]


@kernel
def lagged_torques(t: float, lag1: float, lag3: float, direction: float,
                   p: np.ndarray) -> tuple[float, float]:
    """(T1, T3), N·m, with τ_d > 0: the preload (the nuts', so not through the current
    loops) plus each drive's lagged torque L1, L3, and the fluctuation T_v·sin(ω_v·t) on
    the active pinion as :func:`drive_torques` adds it."""
    fluctuation = 0.0 if p[TV] == 0.0 else p[TV] * math.sin(p[WV] * t)
    if p[MODE] == MODE_CONVENTIONAL:
        return lag1 + direction * fluctuation, 0.0
    if direction > 0.0:
        return p[TP] + lag1 + fluctuation, -p[TP] + lag3
    return p[TP] + lag1, -p[TP] + lag3 - fluctuation


@kernel
def pinion_torques(piece: DrivePiece, t: float, y: tuple, torque: float, direction: float,
                   p: np.ndarray) -> tuple[float, float, DrivePiece]:
    """Torques (T1, T3), N·m, the drives apply to pinions 1 and 3 at state y with the
    drive's line on ``piece`` (FROM_STATE: the piece the speed picks), and that piece:
    τ_d = 0, :func:`applied_torques_on` of the command; τ_d > 0, the lagged torques y[6],
    y[7] (:func:`lagged_torques`). The motors' cogging is a term of its own
    (:func:`~screwgear_ros.physics.torques.torque_terms`)."""
    if p[TAU] == 0.0:
        t1, t3, piece = applied_torques_on(piece, t, y[3], y[5], torque, direction, p)
    else:
        lag1, lag3 = lag_state(y)
        t1, t3 = lagged_torques(t, lag1, lag3, direction, p)
        if piece == DrivePiece.FROM_STATE:
            piece = drive_piece(torque, active_speed(y[3], y[5], direction, p), p)
    return t1, t3, piece


def active_path(mode: Mode, direction: int) -> int:
    """Drive path carrying the commanded torque: 1 (forward) or 3 (reverse, anti-backlash)."""
    return 3 if Mode(mode) is Mode.ANTI_BACKLASH and direction < 0 else 1


@dataclass(frozen=True)
class DriveInput:
    """The input in force: drive torque T ≥ 0 (N·m), direction ±1, table load (N·m)."""

    torque: float = 0.0
    direction: int = 1
    load: float = 0.0

    @classmethod
    def of(cls, torque: float, direction: int, load: float) -> DriveInput:
        """``DriveInput(torque, direction, load)``, made without the frozen dataclass's
        ``object.__setattr__`` per field (its generated ``__init__`` costs several times
        this): the session makes one for every command it applies."""
        drive = object.__new__(cls)
        drive.__dict__.update(torque=torque, direction=direction, load=load)
        return drive

    @property
    def kernel(self) -> Drive:
        """The input as the compiled calls take it (all floats)."""
        return Drive(float(self.torque), float(self.direction), float(self.load))



__all__ = [
    'DrivePiece',
    'active_path',
    'active_speed',
    'applied_torques',
    'applied_torques_on',
    'drive_on',
    'drive_piece',
    'drive_targets',
    'drive_torques',
    'lag_rates',
    'lag_state',
    'lagged_torques',
    'pinion_torques',
]
