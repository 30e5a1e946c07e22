"""A recording made before a parameter existed reads with the value its declaration says
such runs had (``introduced=``, ``before=``), and nothing else is ever filled in.

The ground truth is the checked-in bags: table_sim recorded them with an older version of
the package, before many of today's parameters existed. Their run_parameters messages are
read here with the ``mcap`` library and the ROS 2 typestore of ``rosbags``, not with the
package's bag reader.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml
from bag_runs import BAGS
from mcap.reader import make_reader
from paths import DATA
from rosbags.typesys import Stores, get_typestore

import screwgear_ros
from screwgear_ros.bag.reader import read_run
from screwgear_ros.params.declarations import Parameter, declared, plain, version_key
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.run_file import RunParametersError, dump, load

#: Every bag under test/data (the replayed runs and the real-time demo).
RECORDED = [*BAGS, 'realtime_demo']
STORE = get_typestore(Stores.ROS2_JAZZY)
DECLARED = [*declared(TableParams), *declared(SimSettings)]


def recorded_documents(name: str) -> list[str]:
    """The YAML text of every run_parameters message of bag ``name``, in log order."""
    (path,) = Path(DATA / name).glob('*.mcap')
    with path.open('rb') as stream:
        return [STORE.deserialize_cdr(message.data, 'std_msgs/msg/String').data
                for _, channel, message in make_reader(stream).iter_messages(log_time_order=True)
                if channel.topic.endswith('/run_parameters')]


def loaded_value(run: Any, p: Parameter) -> Any:
    holder = run.params if hasattr(run.params, p.name) else run.settings
    return plain(getattr(holder, p.name))


@pytest.fixture(scope='module')
def documents() -> dict[str, list[str]]:
    return {name: recorded_documents(name) for name in RECORDED}


def test_every_parameter_a_test_bag_lacks_is_declared_newer_than_the_bag(documents):
    """Adding a parameter means saying since when: a bag recorded before it lacks it, and
    only ``introduced=`` newer than the bag's version lets the bag read."""
    current = version_key(screwgear_ros.__version__)
    for p in DECLARED:
        if p.declaration.introduced:
            assert version_key(p.declaration.introduced) <= current, (
                f'{p.name} says introduced={p.declaration.introduced!r}, after the package\'s '
                f'own version {screwgear_ros.__version__}')
    lacked = set()
    for name, texts in documents.items():
        for text in texts:
            document = yaml.safe_load(text)
            version = document['package_version']
            for p in DECLARED:
                if p.name in document:
                    continue
                lacked.add(p.name)
                introduced = p.declaration.introduced
                assert introduced and version_key(introduced) > version_key(version), (
                    f'test/data/{name} was recorded by version {version} without '
                    f'{p.name!r}: declare it with parameter(..., introduced='
                    f"'{screwgear_ros.__version__}', before=<the value runs of {version} had>) "
                    f'(now introduced={introduced!r})')
    assert len(lacked) > 20        # the bags do predate parameters: the loop checked some


def test_the_test_bags_read_with_the_declared_values_of_what_they_predate(documents):
    """Every run_parameters message of every bag loads; a key it has keeps its recorded
    value, a key it lacks takes the declaration's ``before``; the package's bag reader
    gives the same first set."""
    for name, texts in documents.items():
        assert texts, name
        for text in texts:
            document = yaml.safe_load(text)
            run = load(text)
            for p in DECLARED:
                expected = document[p.name] if p.name in document else plain(
                    p.declaration.before)
                assert loaded_value(run, p) == expected, (name, p.name)
        first = load(texts[0])
        recorded = read_run(DATA / name).parameters
        assert (recorded.params, recorded.settings) == (first.params, first.settings), name


def test_a_parameter_removed_from_a_recording_reads_as_its_version_says(documents):
    """The real-time demo was recorded with the drive line. Its set complete (every key),
    without ``drive_no_load_speed``: a document of the bag's version reads with the
    declared ``before`` (not the recorded value), one of today's version (or of no version)
    is refused naming the key, and a key declared from the first version is refused
    whatever the version says."""
    text = documents['realtime_demo'][0]
    document = yaml.safe_load(dump(load(text)))
    assert document['package_version'] == yaml.safe_load(text)['package_version']
    recorded = document.pop('drive_no_load_speed')
    before = next(p for p in DECLARED if p.name == 'drive_no_load_speed').declaration.before
    assert recorded == yaml.safe_load(text)['drive_no_load_speed'] != before
    assert load(yaml.safe_dump(document)).params.drive_no_load_speed == before
    for version in (screwgear_ros.__version__, 'unknown', '0.2', None):
        with pytest.raises(RunParametersError, match=r"lacks \['drive_no_load_speed'\]"):
            load(yaml.safe_dump({**document, 'package_version': version}))
    for version in ('0.0.1', document['package_version']):
        lacking = {k: v for k, v in document.items() if k != 'backlash'}
        with pytest.raises(RunParametersError, match=r"lacks \['backlash'\]") as refused:
            load(yaml.safe_dump({**lacking, 'package_version': version}))
        assert version in str(refused.value)
