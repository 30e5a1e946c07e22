"""A setpoint profile: t (s of simulation time) → target angle (rad) of one joint, as
a scenario writes it (docs/scenarios.md), and its reader."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import yaml

from ..params.yaml_reader import YamlReader

#: The setpoint profiles and their keys (required ones first, then optional with defaults).
PROFILES: dict[str, dict[str, Any]] = {
    'steps': {'points': None},
    'ramps': {'points': None},
    'square': {'amplitude': None, 'period': None, 'offset': 0.0},
    'sine': {'amplitude': None, 'frequency': None, 'offset': 0.0, 'phase': 0.0},
}

@dataclass(frozen=True)
class SetpointProfile:
    """A target profile, t (s of simulation time from the start) → target (rad) of
    ``joint``; see docs/scenarios.md for the profiles."""

    profile: str
    points: tuple[tuple[float, float], ...] = ()    # steps, ramps: (time, value)
    amplitude: float = 0.0
    period: float = 0.0
    frequency: float = 0.0
    offset: float = 0.0
    phase: float = 0.0
    joint: str = 'table'

    def __post_init__(self) -> None:
        """Refuse what no profile can be (ValueError): an unknown profile, a period or
        frequency that is not a finite number > 0, steps or ramps without points."""
        if self.profile not in PROFILES:
            raise ValueError(f'unknown setpoint profile {self.profile!r} (known: '
                             f'{", ".join(PROFILES)})')
        if self.profile == 'square' and not (_positive(self.period) and 0.5 * self.period):
            raise ValueError(f'a square setpoint period must be a finite number of '
                             f'seconds > 0, not {self.period!r}')
        if self.profile == 'sine' and not _positive(self.frequency):
            raise ValueError(f'a sine setpoint frequency must be a finite number of '
                             f'hertz > 0, not {self.frequency!r}')
        if self.profile in ('steps', 'ramps') and not self.points:
            raise ValueError(f'a {self.profile} setpoint needs points')

    def check_tick(self, tick: float) -> None:
        """Refuse (ValueError, with the bound) a square period shorter than two ticks of
        ``tick`` s: a wave that flips within a tick is not sampled, and its jumps would
        number one per half period over the run."""
        if self.profile == 'square' and self.period < 2.0 * tick:
            raise ValueError(f'a square setpoint period must be at least two ticks '
                             f'({2.0 * tick:g} s at this publish_rate and dt), not '
                             f'{self.period:g} s')

    def __call__(self, t: float) -> float:
        p = self.profile
        if p == 'sine':
            return self.offset + self.amplitude * math.sin(
                2.0 * math.pi * self.frequency * t + self.phase)
        if p == 'square':
            return self.offset + (self.amplitude if (t // (0.5 * self.period)) % 2 == 0
                                  else -self.amplitude)
        points = self.points
        if t < points[0][0]:
            return points[0][1]
        for (t0, v0), (t1, v1) in itertools.pairwise(points):
            if t < t1:
                return v0 if p == 'steps' else v0 + (v1 - v0) * (t - t0) / (t1 - t0)
        return points[-1][1]

    def steps(self, duration: float) -> list[tuple[float, float, float]]:
        """The setpoint's jumps within ``duration``: (time, value before, value after);
        empty for a profile without jumps (ramps, sine)."""
        if self.profile == 'steps':
            jumps, before = [], self.points[0][1]
            for t, v in self.points:
                if t <= duration and v != before:
                    jumps.append((t, before, v))
                before = v
            return jumps
        if self.profile == 'square':
            half = 0.5 * self.period
            return [(k * half, self((k - 0.5) * half), self(k * half))
                    for k in range(1, int(duration / half) + 1) if k * half <= duration]
        return []


def _positive(value: float) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value) and value > 0.0)


def read_setpoint(reader: YamlReader, node: yaml.Node,
                  tick: float | None = None) -> SetpointProfile:
    """The scenario file's ``setpoint`` mapping at ``node``, checked (errors name its line);
    ``tick``: the run's tick, s, which a square period must span twice
    (:meth:`SetpointProfile.check_tick`)."""
    entries = reader.mapping(node, 'setpoint')
    if 'profile' not in entries:
        raise reader.error(node, f'setpoint needs a profile: one of {", ".join(PROFILES)}')
    _profile_key, profile_node = entries['profile']
    profile = reader.value(profile_node)
    if profile not in PROFILES:
        raise reader.error(profile_node, f'unknown setpoint profile {profile!r} (known: '
                           f'{", ".join(PROFILES)})')
    keys = PROFILES[profile]
    reader.known(entries, ('profile', 'joint', *keys), f'key of a {profile} setpoint')
    for name, default in keys.items():
        if default is None and name not in entries:
            raise reader.error(node, f'a {profile} setpoint needs {name!r}')
    values: dict[str, Any] = {}
    if 'joint' in entries:
        joint = reader.value(entries['joint'][1])
        if not isinstance(joint, str) or not joint:
            raise reader.error(entries['joint'][1], 'setpoint joint must be a joint name')
        values['joint'] = joint
    for name in keys:
        if name not in entries:
            continue
        _key, value = entries[name]
        if name == 'points':
            values['points'] = _points(reader, value)
        else:
            positive = name in ('period', 'frequency')
            values[name] = reader.number(value, f'setpoint {name}', low=0.0 if positive else None,
                                         strict=positive)
    try:
        setpoint = SetpointProfile(profile, **values)
        if tick is not None:
            setpoint.check_tick(tick)
    except ValueError as exc:
        raise reader.error(entries.get('period', (None, node))[1], str(exc)) from None
    return setpoint


def _points(reader: YamlReader, node: yaml.Node) -> tuple[tuple[float, float], ...]:
    if not isinstance(node, yaml.SequenceNode) or not node.value:
        raise reader.error(node, 'setpoint points must be a list of [time, value] pairs')
    points: list[tuple[float, float]] = []
    for item in node.value:
        if not isinstance(item, yaml.SequenceNode) or len(item.value) != 2:
            raise reader.error(item, 'a setpoint point is [time, value] (s, rad)')
        t = reader.number(item.value[0], 'a setpoint time', low=0.0)
        v = reader.number(item.value[1], 'a setpoint value')
        if points and t <= points[-1][0]:
            raise reader.error(item, f'setpoint times must increase ({t:g} s after '
                               f'{points[-1][0]:g} s)')
        points.append((t, v))
    return tuple(points)


__all__ = ['PROFILES', 'SetpointProfile', 'read_setpoint']
