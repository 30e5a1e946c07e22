"""A bag without run_parameters (an older bag, a hardware bag, a recording that started
after the node did): ``check_run --params FILE.yaml`` checks it against those parameters
and says where they came from; without --params it is refused, naming --params."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import yaml
from bag_runs import copy_bag
from paths import DATA

from screwgear_ros.cli.check_run import main as check_run_main
from screwgear_ros.sim.run_file import load

BAG = DATA / 'steady_drive'


def check(*args: object) -> tuple[int, list[str], str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = check_run_main([*map(str, args), '--no-progress', '--serial'])
    assert 'Traceback' not in err.getvalue(), err.getvalue()
    return code, out.getvalue().splitlines()[1:], err.getvalue()


def without_parameters(tmp_path: Path) -> tuple[Path, Path]:
    """A copy of BAG without its run_parameters, and a parameter file (table_sim's
    format) of the parameters its first run_parameters held."""
    texts: list[str] = []

    def drop(topic: str, msgtype: str, log_time: int, raw: bytes):
        if topic.endswith('/run_parameters'):
            from rosbags.typesys import Stores, get_typestore
            texts.append(get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(raw, msgtype).data)
            return None
        return log_time, raw
    bag = tmp_path / 'bare'
    copy_bag(BAG, bag, drop)
    start = load(texts[0])
    assert start.start_step == 0
    values = {**start.params.as_dict(), **start.settings.as_dict()}
    params = tmp_path / 'params.yaml'
    params.write_text(yaml.safe_dump({'/**': {'ros__parameters': values}}))
    return bag, params


def test_a_bag_without_run_parameters_checks_against_a_parameter_file(tmp_path):
    bag, params = without_parameters(tmp_path)
    code, report, _ = check(BAG)
    assert code == 0 and "  parameters: the bag's run_parameters" in report
    given_code, given, _ = check(bag, '--params', params)
    assert given_code == 0, given
    assert f'  parameters: {params} (--params)' in given
    same = [line for line in report if 'parameters:' not in line and 'recorded events' not in line]
    assert [line for line in given if line in same] == same


def test_without_params_it_is_refused_naming_params(tmp_path):
    bag, params = without_parameters(tmp_path)
    code, _, err = check(bag)
    assert code == 2 and 'no run_parameters' in err and '--params' in err, err
    code, _, err = check(BAG, '--params', params)       # a bag that has its own
    assert code == 2 and 'holds its own run_parameters' in err, err
    params.write_text('/**:\n  ros__parameters:\n    dt: -1.0\n')
    code, _, err = check(bag, '--params', params)
    assert code == 2 and f'with --params {params}' in err and 'dt' in err, err
