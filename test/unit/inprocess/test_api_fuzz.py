"""Seeded fuzz of the in-process API's inputs: Simulation.step / run and the parameter
files from_yaml reads. Every hostile value ends in the documented exception (InputRejected,
ValueError, ParameterFileError naming the file), never OverflowError, TypeError,
MemoryError, UnicodeDecodeError or RecursionError; and a run too long for memory is
refused before it starts."""

from __future__ import annotations

import random
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from screwgear_ros.inprocess.simulation import Observation, RunInProgress, Simulation
from screwgear_ros.sim.commands import InputRejected
from screwgear_ros.sim.events import Command, Reset, Setpoint
from screwgear_ros.sim.parameter_file import ParameterFileError

SEED = 3701
CASES = 300
#: Wall time a family may take, s (the machine is shared: generous, but bounded).
BUDGET = 120.0


def shown(value: Any) -> str:
    """repr for a failure message, safe for ints past the interpreter's digit limit."""
    try:
        return repr(value)[:80]
    except ValueError:
        return f'<{type(value).__name__} with a huge int>'


def hostile_number(rng: random.Random) -> Any:
    """A value where a command's number goes: mostly things no message can carry."""
    kind = rng.randrange(12)
    if kind == 0:
        return rng.choice((1, -1)) * 10 ** rng.randint(309, 5000)      # beyond float64
    if kind == 1:
        return np.array([rng.uniform(-1, 1)] * rng.randint(0, 3))      # an array, any length
    if kind == 2:
        return rng.choice(('abc', '', '1.0', b'\x00'))
    if kind == 3:
        return {'value': rng.random()}
    if kind == 4:
        return rng.choice((float('nan'), float('inf'), -float('inf')))
    if kind == 5:
        return [rng.uniform(-1e3, 1e3) for _ in range(rng.randint(0, 3))]
    if kind == 6:
        return rng.choice((True, False))
    if kind == 7:
        return np.float64(rng.uniform(-1e3, 1e3))
    if kind == 8:
        return complex(rng.random(), 1.0)
    if kind == 9:
        return np.array(rng.uniform(-1.0, 1.0))                      # 0-d
    if kind == 10:
        return object()
    return rng.uniform(-1e4, 1e4)


def test_step_refuses_what_no_message_carries() -> None:
    rng = random.Random(SEED)
    sim = Simulation()
    sim.reset()
    started = time.monotonic()
    refused = 0
    for case in range(CASES):
        argument = rng.choice(('effort', 'torque', 'direction', 'load'))
        value = hostile_number(rng)
        if argument == 'effort' and not isinstance(value, (list, np.ndarray)):
            value = value if rng.random() < 0.5 else [value]
        step = sim.session.step
        try:
            out = sim.step(**{argument: value})
        except InputRejected as exc:
            refused += 1
            assert sim.session.step == step, f'seed {SEED} case {case}: refused but integrated'
            assert exc.topic, f'seed {SEED} case {case}'
        except Exception as exc:  # noqa: BLE001 - the finding: anything undocumented
            pytest.fail(f'seed {SEED} case {case}: step({argument}={shown(value)}) raised '
                        f'{type(exc).__name__}: {exc}')
        else:
            assert isinstance(out, Observation)
        assert time.monotonic() - started < BUDGET, f'seed {SEED}: over budget at case {case}'
    assert refused > CASES // 3


def test_run_refuses_a_duration_or_answer_it_cannot_hold() -> None:
    rng = random.Random(SEED + 1)
    sim = Simulation()
    started = time.monotonic()
    for case in range(CASES):
        kind = rng.randrange(4)
        if kind == 0:             # durations beyond float64, non-finite, absurd, negative
            duration = rng.choice((10 ** rng.randint(309, 2000), float('nan'), -1.0,
                                   10.0 ** rng.randint(9, 300), 'abc', None))
            with pytest.raises(ValueError, match='duration') as info:
                sim.run(None, duration)
            assert len(str(info.value)) < 400, f'seed {SEED + 1} case {case}'
        elif kind == 1:           # a controller answering what no message carries
            answer = hostile_number(rng)
            try:
                sim.run(lambda _o, a=answer: a, 2 * sim.tick_period)
            except InputRejected:
                pass
            except Exception as exc:  # noqa: BLE001
                pytest.fail(f'seed {SEED + 1} case {case}: controller -> {shown(answer)}: '
                            f'{type(exc).__name__}: {exc}')
        elif kind == 2:           # reset() or step() inside the controller
            inside = rng.choice((sim.reset, sim.step))

            def resetting(_o: Any, inside: Any = inside) -> float:
                inside()
                return 0.0
            with pytest.raises(RunInProgress, match=r'(reset|step)\(\) during run'):
                sim.run(resetting, rng.randint(1, 3) * sim.tick_period)
        else:                     # an ordinary short run still runs
            run = sim.run(lambda _o: rng.uniform(-400, 400), rng.randint(0, 3) * sim.tick_period)
            assert len(run) >= 1
        assert time.monotonic() - started < BUDGET, f'seed {SEED + 1}: over budget at {case}'


def hostile_event(rng: random.Random) -> Any:
    """An element of run()'s ``events``: a session event with a hostile step or value,
    or something that is no event."""
    kind = rng.randrange(7)
    step = rng.choice((None, -1, 2.5, float('nan'), 'x', True, 10**30, np.int64(40),
                       rng.randrange(0, 200)))
    if kind == 0:
        return Setpoint(hostile_number(rng), step=rng.randrange(0, 200))
    if kind == 1:
        return Command('cmd_torque', hostile_number(rng), step=rng.randrange(0, 200))
    if kind == 2:
        return Reset(step=step)
    if kind == 3:
        return Command('cmd_effort', [rng.uniform(-50.0, 50.0)], step=step)
    if kind == 4:
        return rng.choice(('reset', None, 3, {'step': 0}, (Reset(step=0),)))
    if kind == 5:
        return Command('no_such_topic', 1.0, step=rng.randrange(0, 200))
    return Setpoint(rng.uniform(-1, 1), step=rng.randrange(0, 200))


def test_run_refuses_hostile_events_and_setpoints_by_name(tmp_path: Path) -> None:
    """run()'s ``events`` (elements that are no event, steps that are no integer >= 0,
    commands and setpoints holding anything) and ``setpoint`` callables that return
    anything: a refusal names ``events[i]`` or ``setpoint(t)`` and is a ValueError, a
    command the node refuses is kept in the run's ``rejected``, and no other exception
    reaches the caller; the run of what is accepted completes (recorded setpoints only
    matter to a recording, so half the cases record)."""
    seed = SEED + 7
    rng = random.Random(seed)
    sim = Simulation.from_values(publish_rate=500.0)
    started = time.monotonic()
    for case in range(150):
        events = [hostile_event(rng) for _ in range(rng.randint(0, 4))]
        answer = hostile_number(rng) if rng.random() < 0.5 else 0.1
        target = None if rng.random() < 0.3 else (lambda _t, a=answer: a)
        record = tmp_path / f'run{case}' if rng.random() < 0.15 else None
        try:
            run = sim.run(None, 20 * sim.tick_period, record, events=events, setpoint=target)
        except ValueError as exc:
            assert 'events[' in str(exc) or 'setpoint(t)' in str(exc), \
                f'seed {seed} case {case}: {type(exc).__name__}: {exc}'
            assert 'Error' not in str(exc), f'seed {seed} case {case}: {exc}'
        except Exception as exc:  # noqa: BLE001 - the finding this family looks for
            pytest.fail(f'seed {seed} case {case}: events {shown(events)}, setpoint -> '
                        f'{shown(answer)}: {type(exc).__name__}: {exc}')
        else:
            assert len(run) == 21, f'seed {seed} case {case}'
        assert time.monotonic() - started < BUDGET, f'seed {seed}: over budget at {case}'


def _hostile_file(rng: random.Random, path: Path) -> bytes:
    """A parameter file with one thing a reader must survive."""
    good = '/**:\n  ros__parameters:\n    dt: 5.0e-05\n    publish_rate: 1000.0\n'
    kind = rng.randrange(6)
    if kind == 0:             # an integer (or float, bool) key beside the names
        key = rng.choice(('1', '2.5', 'true', 'null', '[1]'))
        return (good + f'    {key}: 2\n').encode()
    if kind == 1:             # bytes that are not UTF-8
        text = bytearray(good.encode())
        text[rng.randrange(len(text))] = rng.choice((0xff, 0xfe, 0xc0, 0x80))
        return bytes(text)
    if kind == 2:             # nesting deeper than a recursive reader follows
        depth = rng.randint(1200, 6000)
        opener, closer = rng.choice((('[', ']'), ('{a: ', '}')))
        return ('/**:\n  ros__parameters:\n    dt: ' + opener * depth + closer * depth
                + '\n').encode()
    if kind == 3:             # a control character
        text = list(good)
        text.insert(rng.randrange(len(text)), chr(rng.choice((1, 2, 7, 8, 0x1b, 0x7f))))
        return ''.join(text).encode()
    if kind == 4:             # an integer key at the top
        return f'{rng.randint(0, 99)}:\n  ros__parameters:\n    dt: 5.0e-05\n'.encode()
    return good.encode()


def test_from_yaml_refuses_a_hostile_file_naming_it(tmp_path: Path) -> None:
    rng = random.Random(SEED + 2)
    started = time.monotonic()
    for case in range(CASES):
        path = tmp_path / f'p{case}.yaml'
        path.write_bytes(_hostile_file(rng, path))
        try:
            Simulation.from_yaml(path)
        except (ParameterFileError, ValueError) as exc:
            assert str(path) in str(exc), f'seed {SEED + 2} case {case}: {exc}'
        except Exception as exc:  # noqa: BLE001
            pytest.fail(f'seed {SEED + 2} case {case}: {path.read_bytes()[:80]!r}: '
                        f'{type(exc).__name__}: {exc}')
        assert time.monotonic() - started < BUDGET, f'seed {SEED + 2}: over budget at {case}'


def test_the_named_cases_end_in_their_documented_errors(tmp_path: Path) -> None:
    """The cases that were seen, one by one, with the words of the refusal."""
    sim = Simulation()
    sim.reset()
    for kwargs in ({'effort': 10**400}, {'load': 10**400}, {'direction': np.array([1.0])}):
        with pytest.raises(InputRejected, match='cannot carry'):
            sim.step(**kwargs)
    with pytest.raises(InputRejected, match='beyond float64'):
        sim.run(lambda _o: 10**400, 0.01)
    with pytest.raises(ValueError, match='duration'):
        sim.run(None, 10**400)
    with pytest.raises(ValueError, match='GiB of samples'):
        sim.run(None, 1e12)
    deep = tmp_path / 'deep.yaml'
    deep.write_text('dt: ' + '[' * 5000 + ']' * 5000 + '\n')
    with pytest.raises(ParameterFileError, match='deeper than'):
        Simulation.from_yaml(deep)
    latin = tmp_path / 'latin.yaml'
    latin.write_bytes(b'dt: 5.0e-05\nmode: \xe9\n')
    with pytest.raises(ParameterFileError, match=r'line 2: not UTF-8'):
        Simulation.from_yaml(latin)
    keyed = tmp_path / 'keyed.yaml'
    keyed.write_text('/**:\n  ros__parameters:\n    dt: 5.0e-05\n    1: 2\n')
    with pytest.raises(ParameterFileError, match=r'line 4: .*a key must be a name'):
        Simulation.from_yaml(keyed)
