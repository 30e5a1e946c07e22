"""Seeded fuzz families over what a sweep reads: the sweep file, its base parameter file
and its results directory. Whatever they hold, ``load_sweep`` gives a sweep or a
SweepError that names the file, and a results directory is taken, refused with a
SweepError, or has its damaged run files listed for rerunning: never another exception,
never a draw outside its window, never a run count built before it is bounded.

Each family draws its cases from ``random.Random(SEED)``; a failure names the seed, the
case number and the input. The case kinds are those a hostile user found (a scale on a
text parameter, a range wider than the largest float, a non-UTF-8 or dated base file, a
control character, deep nesting, a billion runs, a truncated normal's far tail, a results
directory that holds something else, damaged run files)."""

from __future__ import annotations

import datetime
import json
import math
import random
import time
from pathlib import Path

import pytest

from screwgear_ros.sim.parameter_set import default_values
from screwgear_ros.sweep.model import SweepError
from screwgear_ros.sweep.spec import SWEEPABLE, load_sweep
from screwgear_ros.sweep.store import Store

SEED = 3705
#: Cases per family (the kinds of a family share its cases in turn).
FILE_CASES, BASE_CASES, DIRECTORY_CASES, RUN_FILE_CASES = 240, 60, 60, 40
#: The most runs these tests let a sweep resolve: larger ones must be refused first.
LIMIT = 200

SCENARIO = 'parameters: {command_timeout: 0.0}\nduration: 0.05\n'
HEAD = 'scenario: scenario.yaml\nmetrics: [max_abs_te_m]\n'
TEXT_PARAMETERS = [name for name, value in default_values().items() if name in SWEEPABLE
                   and (isinstance(value, (bool, str))
                        or (isinstance(value, list) and not all(
                            isinstance(v, (int, float)) and not isinstance(v, bool)
                            for v in value)))]
NUMBER_PARAMETERS = sorted(name for name, value in default_values().items()
                           if name in SWEEPABLE and isinstance(value, float))
CONTROL = [c for c in range(32) if chr(c) not in '\t\n\r'] + [0x7f, 0x85 - 1, 0x9f]
ODD_VALUES = ['2024-01-01', '2024-01-01 10:00:00', '{a: 1}', '[[1, 2], [3]]', '.nan',
              '.inf', '-.inf', '1' + '0' * 400, '!!binary aGVsbG8=', '!!set {a, b}', 'null',
              'yes', '~', "'1e-5'", '0x10', '1_000', '!!float 1e400']


@pytest.fixture(scope='module')
def home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp('fuzz_sweep')
    (directory / 'scenario.yaml').write_text(SCENARIO)
    return directory


def _outcome(path: Path, what: str, **kwargs: object) -> object:
    """load_sweep's sweep, or its SweepError (one line, naming the file)."""
    try:
        return load_sweep(path, limit=LIMIT, **kwargs)
    except SweepError as exc:
        text = str(exc)
        assert text.startswith(f'{path}:') and '\n' not in text, (what, text)
        return exc
    except Exception as exc:  # noqa: BLE001 - what the family looks for
        pytest.fail(f'{what}: {type(exc).__name__}: {exc}')


def _deep(rng: random.Random) -> str:
    depth = rng.randint(300, 1500)
    opener = rng.choice(['[', '{a: '])
    closer = ']' if opener == '[' else '}'
    return opener * depth + '1.0' + closer * depth


def _truncated(rng: random.Random) -> tuple[str, tuple[float, ...]]:
    mean, std = rng.uniform(-10.0, 10.0), 10.0 ** rng.uniform(-3, 2)
    near = rng.choice([rng.uniform(-8.0, 8.0), rng.uniform(5.0, 400.0),
                       -rng.uniform(5.0, 400.0)])
    width = 10.0 ** rng.uniform(-2, 2)
    low, high = (near, near + width) if rng.random() < 0.5 else (near - width, near)
    args = tuple(float(f'{a:.6e}') for a in (mean, std, mean + low * std, mean + high * std))
    return '[' + ', '.join(f'{a:.6e}' for a in args) + ']', args


def _sweep_file(rng: random.Random, kind: str) -> tuple[str, tuple[float, ...] | None]:
    """A sweep file of ``kind``, and a truncated normal's arguments when it draws one."""
    if kind == 'scale_on_text':
        name = rng.choice(TEXT_PARAMETERS)
        if rng.random() < 0.5:
            return HEAD + f'grid:\n  {name}: {{scale: [1.0, 2.0]}}\n', None
        return (HEAD + 'monte_carlo:\n  count: 2\n  parameters:\n'
                f'    {name}: {{scale: {{uniform: [0.5, 1.5]}}}}\n'), None
    if kind == 'huge_range':
        big = [1.0e+308, 1.7e+308, 1.79e+308, 9.0e+307, 1.0e+300, 1.0e+154]
        law = rng.choice(['uniform', 'normal', 'truncated_normal'])
        a, b = -rng.choice(big), rng.choice(big)
        args = {'uniform': [a, b], 'normal': [rng.choice([0.0, a]), b],
                'truncated_normal': [0.0, b, a, rng.choice(big)]}[law]
        text = ', '.join(f'{v:.4e}' for v in args)
        return (HEAD + f'monte_carlo:\n  count: 3\n  seed: {rng.randint(0, 99)}\n  parameters:\n'
                f'    backlash: {{{law}: [{text}]}}\n'), None
    if kind == 'control_character':
        base = HEAD + 'grid:\n  backlash: [0.0, 1.0e-5]\n'
        at = rng.randint(0, len(base))
        return base[:at] + chr(rng.choice(CONTROL)) + base[at:], None
    if kind == 'deep_nesting':
        where = rng.choice(['grid:\n  backlash: {}\n', 'monte_carlo: {}\n',
                            'metrics_extra: {}\n', 'grid:\n  preload_torque: [{}]\n'])
        return HEAD + where.format(_deep(rng)), None
    if kind == 'odd_value':
        value = rng.choice(ODD_VALUES)
        slot = rng.choice(['grid:\n  backlash: [{}]\n', 'grid:\n  backlash: {{scale: [{}]}}\n',
                           ('monte_carlo:\n  count: {}\n  parameters:\n    backlash: '
                           '{{uniform: [0.0, 1.0e-5]}}\n'),
                           ('monte_carlo:\n  count: 2\n  seed: {}\n  parameters:\n    backlash: '
                           '{{uniform: [0.0, 1.0e-5]}}\n'),
                           'time_limit: {}\ngrid:\n  backlash: [0.0]\n',
                           ('monte_carlo:\n  count: 2\n  parameters:\n    backlash: '
                           '{{normal: [{}, 1.0e-6]}}\n'),
                           'grid:\n  joint_names: [{}]\n', 'grid:\n  mode: [{}]\n'])
        return HEAD + slot.format(value), None
    if kind == 'too_many_runs':
        if rng.random() < 0.5:
            count = 10 ** rng.randint(4, 12)
            return (HEAD + f'monte_carlo:\n  count: {count}\n  parameters:\n'
                    '    backlash: {uniform: [0.0, 1.0e-5]}\n'), None
        names = rng.sample(NUMBER_PARAMETERS, rng.randint(2, 6))
        axes = ''.join(f'  {n}: [{", ".join(f"{k}.0" for k in range(rng.randint(20, 100)))}]\n'
                       for n in names)
        return HEAD + 'grid:\n' + axes, None
    if kind == 'truncated_tail':
        text, args = _truncated(rng)
        return (HEAD + f'monte_carlo:\n  count: 4\n  seed: {rng.randint(0, 999)}\n'
                f'  parameters:\n    temperature_rise: {{truncated_normal: {text}}}\n'), args
    assert kind == 'random_bytes'
    base = HEAD + 'grid:\n  backlash: [0.0, 1.0e-5]\n'
    raw = bytearray(base.encode())
    at = rng.randint(0, len(raw))
    raw[at:at + rng.randint(0, 6)] = bytes(rng.randint(0, 255) for _ in range(rng.randint(1, 6)))
    return raw.decode('latin-1'), None


FILE_KINDS = ('scale_on_text', 'huge_range', 'control_character', 'deep_nesting', 'odd_value',
              'too_many_runs', 'truncated_tail', 'random_bytes')


def test_sweep_files_give_a_sweep_or_a_sweep_error(home: Path) -> None:
    rng = random.Random(SEED)
    seen = dict.fromkeys(FILE_KINDS, 0)
    started = time.monotonic()
    for case in range(FILE_CASES):
        kind = FILE_KINDS[case % len(FILE_KINDS)]
        text, truncated = _sweep_file(rng, kind)
        path = home / f'sweep_{case}.yaml'
        if kind == 'random_bytes':
            path.write_bytes(text.encode('latin-1'))
        else:
            path.write_text(text, encoding='utf-8')
        what = f'seed {SEED} case {case} ({kind}): {text[:160]!r}'
        clock = time.monotonic()
        outcome = _outcome(path, what)
        seen[kind] += 1
        if kind in ('scale_on_text', 'control_character', 'deep_nesting', 'too_many_runs'):
            assert isinstance(outcome, SweepError), what
        if kind == 'too_many_runs':         # refused from its count, before any run is built
            assert 'more than the limit' in str(outcome) and time.monotonic() - clock < 2.0, \
                (what, str(outcome))
        if kind == 'truncated_tail' and not isinstance(outcome, SweepError):
            assert truncated is not None
            _check_truncated(outcome, truncated, what)
        if kind == 'huge_range' and not isinstance(outcome, SweepError):
            assert all(math.isfinite(v) for r in outcome.runs for _, v in r.swept), what
    assert time.monotonic() - started < 240.0
    assert all(n >= FILE_CASES // len(FILE_KINDS) for n in seen.values()), seen


def _check_truncated(sweep: object, args: tuple[float, ...], what: str) -> None:
    """Every draw in its window; a window wholly beyond 5 σ draws next to its nearer edge,
    within a few times σ² / distance of it (the tail's scale), never at the far edge."""
    mean, std, low, high = args
    values = [v for r in sweep.runs for _, v in r.swept]          # type: ignore[attr-defined]
    assert all(low <= v <= high for v in values), (what, values)
    a, b = (low - mean) / std, (high - mean) / std
    if a > 6.0 and (high - low) > 20.0 * std / a:
        assert all(v - low < 20.0 * std / a for v in values), (what, values)
    if b < -6.0 and (high - low) > 20.0 * std / -b:
        assert all(high - v < 20.0 * std / -b for v in values), (what, values)


def _base_file(rng: random.Random, kind: str) -> bytes:
    if kind == 'not_utf8':
        good = b'backlash: 1.0e-5\n'
        return good + bytes([rng.choice([0x80, 0xc3, 0xff, 0xfe, 0xe9])]) + b'\n'
    if kind == 'date':
        when = datetime.date(2000, 1, 1) + datetime.timedelta(days=rng.randint(0, 9999))
        return f'{rng.choice(["note", "backlash", "/**"])}: {when.isoformat()}\n'.encode()
    if kind == 'nested':
        return rng.choice([b'backlash: {a: {b: 1}}\n', b'backlash: [[1.0]]\n',
                           b'/**: {ros__parameters: {backlash: {x: 1}}}\n',
                           b'/**: {ros__parameters: 5}\n'])
    if kind == 'deep':
        return f'backlash: {_deep(rng)}\n'.encode()
    if kind == 'control':
        return f'backlash: 1.0e-5{chr(rng.choice(CONTROL))}\n'.encode()
    return rng.choice([b'42\n', b'hello\n', b'[1, 2]\n', b'- a\n- b\n', b'{1: 2, a: 3}\n',
                       b': :\n', b'"unterminated\n'])


BASE_KINDS = ('not_utf8', 'date', 'nested', 'deep', 'control', 'odd_document')


def test_base_files_give_a_sweep_or_a_sweep_error(home: Path) -> None:
    rng = random.Random(SEED + 1)
    for case in range(BASE_CASES):
        kind = BASE_KINDS[case % len(BASE_KINDS)]
        content = _base_file(rng, kind)
        (home / f'base_{case}.yaml').write_bytes(content)
        path = home / f'with_base_{case}.yaml'
        path.write_text(f'parameters: base_{case}.yaml\n' + HEAD + 'grid:\n  backlash: [0.0]\n')
        what = f'seed {SEED + 1} case {case} ({kind}): base file {content[:120]!r}'
        outcome = _outcome(path, what)
        if kind != 'odd_document':
            assert isinstance(outcome, SweepError) and 'line 1:' in str(outcome), what


@pytest.fixture(scope='module')
def sweep(home: Path) -> object:
    path = home / 'small.yaml'
    path.write_text(HEAD + 'grid:\n  backlash: [0.0, 1.0e-5, 2.0e-5, 3.0e-5]\n')
    return load_sweep(path)


def test_results_directories_are_taken_or_refused_with_a_sweep_error(home: Path,
                                                                     sweep: object) -> None:
    rng = random.Random(SEED + 2)
    contents = ['42', 'hello', '[1, 2]', '', '~', '- a', '{', '"x', '\x07', '[' * 3000,
                'sweep_file: x\nruns: 5\n', '{1: 2}']
    for case in range(DIRECTORY_CASES):
        out = home / f'out_{case}'
        choice = rng.randrange(4)
        if choice == 0:
            out.write_text(rng.choice(['x', '', 'sweep']))
            what = 'an existing file'
        elif choice == 1:
            out = Path('/dev/null')
            what = '/dev/null'
        else:
            out.mkdir()
            text = rng.choice(contents) if choice == 2 else \
                bytes(rng.randint(0, 255) for _ in range(rng.randint(1, 40))).decode('latin-1')
            (out / 'sweep.yaml').write_bytes(text.encode('latin-1', 'replace')
                                             if choice == 3 else text.encode())
            what = f'sweep.yaml holding {text[:40]!r}'
        what = f'seed {SEED + 2} case {case}: --out {what}'
        try:
            Store(out, sweep).open()                               # type: ignore[arg-type]
        except SweepError as exc:
            assert '\n' not in str(exc), (what, str(exc))
        except Exception as exc:  # noqa: BLE001 - what the family looks for
            pytest.fail(f'{what}: {type(exc).__name__}: {exc}')
        else:
            pytest.fail(f'{what}: taken as a results directory')


def _damaged(rng: random.Random, row: dict[str, object]) -> str:
    kind = rng.randrange(9)
    row = dict(row)
    if kind == 0:
        del row[rng.choice(['index', 'key', 'status', 'reason', 'metrics'])]
    elif kind == 1:
        row['metrics'] = rng.choice([[], [1.0, 2.0], 'x', None, {'a': 1}, [[1.0]], [True],
                                     ['1.0']])
    elif kind == 2:
        row['status'] = rng.choice([5, None, 'okay', '', ['ok'], 'OK'])
    elif kind == 3:
        row['index'] = rng.choice(['0', 1.5, None, [0], True, -1, 10 ** 30])
    elif kind == 4:
        row['reason'] = rng.choice([None, 3, ['x']])
    elif kind == 5:
        return json.dumps(row)[:rng.randint(0, 20)]
    elif kind == 6:
        return rng.choice(['[]', '42', '"row"', 'null', '\udcff', '{"index": 0}'])
    elif kind == 7:
        return '[' * 100_000 + ']' * 100_000
    else:
        row['key'] = rng.choice([None, 7, ['k']])
    return json.dumps(row)


def test_damaged_run_files_are_listed_and_their_runs_left_to_do(home: Path,
                                                                sweep: object) -> None:
    from screwgear_ros.sweep.worker import Outcome, Status

    rng = random.Random(SEED + 3)
    runs = sweep.runs                                              # type: ignore[attr-defined]
    for case in range(RUN_FILE_CASES):
        out = home / f'runs_{case}'
        store = Store(out, sweep)                                  # type: ignore[arg-type]
        store.open()
        rows = {r.index: store.add(Outcome(r.index, r.key, Status.OK, '', (0.5,), 0.1))
                for r in runs}
        broken = set(rng.sample(sorted(rows), rng.randint(1, len(rows))))
        texts = {}
        for index in broken:
            texts[index] = _damaged(rng, rows[index])
            (out / 'runs' / f'{index:06d}.json').write_text(texts[index], encoding='utf-8',
                                                            errors='surrogateescape')
        what = f'seed {SEED + 3} case {case}: damaged {texts}'
        try:
            done = store.finished()
        except Exception as exc:  # noqa: BLE001 - what the family looks for
            pytest.fail(f'{what}: {type(exc).__name__}: {exc}')
        assert set(done) == set(rows) - broken, what
        assert {int(p.name[:6]) for p, _ in store.damaged} == broken, (what, store.damaged)
