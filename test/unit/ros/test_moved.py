"""The nodes live in ros/ and the sweep's data in sweep.model; their old paths still
answer for one release, with a DeprecationWarning naming the new one. And the errors of
the ROS shell and the sweeps are ScrewgearErrors of the built-in they specialize."""

from __future__ import annotations

import importlib

import pytest

from screwgear_ros.errors import ScrewgearError


@pytest.mark.parametrize('old, name, new', [
    ('screwgear_ros.cli.table_sim', 'TableSim', 'screwgear_ros.ros.node'),
    ('screwgear_ros.cli.sweep', 'rerun_file', 'screwgear_ros.sweep.report'),
    ('screwgear_ros.sweep.spec', 'Bundle', 'screwgear_ros.sweep.model'),
    ('screwgear_ros.sweep.spec', 'RunSpec', 'screwgear_ros.sweep.model'),
    ('screwgear_ros.sweep.spec', 'run_seed', 'screwgear_ros.sweep.model'),
])
def test_a_moved_name_warns_and_is_the_new_one(old, name, new):
    with pytest.warns(DeprecationWarning, match=new.replace('.', r'\.')):
        found = getattr(importlib.import_module(old), name)
    assert found is getattr(importlib.import_module(new), name)


@pytest.mark.parametrize('old, name, new, new_name', [
    ('screwgear_ros.cli.demo_controller', 'DemoController', 'screwgear_ros.ros.demo_controller',
     'DemoControllerNode'),
    ('screwgear_ros.ros.demo_controller', 'DemoController', 'screwgear_ros.ros.demo_controller',
     'DemoControllerNode'),
    ('screwgear_ros.bag.cdr', 'Bundle', 'screwgear_ros.bag.cdr', 'MessageBundle'),
])
def test_a_renamed_name_warns_and_is_the_new_one(old, name, new, new_name):
    """A name with two meanings in the package was renamed where it meant the other thing."""
    with pytest.warns(DeprecationWarning, match=f'{new}.{new_name}'.replace('.', r'\.')):
        found = getattr(importlib.import_module(old), name)
    assert found is getattr(importlib.import_module(new), new_name)


def test_an_unknown_name_is_still_an_attribute_error():
    module = importlib.import_module('screwgear_ros.cli.table_sim')
    with pytest.raises(AttributeError):
        module.NoSuchThing  # noqa: B018


@pytest.mark.parametrize('module, name, builtin', [
    ('screwgear_ros.ros.launch_support', 'MissingPackages', RuntimeError),
    ('screwgear_ros.ros.param_dump', 'Unwritable', ValueError),
    ('screwgear_ros.sweep.model', 'SweepError', ValueError),
])
def test_the_errors_are_screwgear_errors(module, name, builtin):
    error = getattr(importlib.import_module(module), name)
    assert issubclass(error, ScrewgearError) and issubclass(error, builtin)
