"""The errors of the ROS shell and the sweeps are ScrewgearErrors of the built-in they
specialize."""

from __future__ import annotations

import importlib

import pytest

from screwgear_ros.errors import ScrewgearError


@pytest.mark.parametrize('module, name, builtin', [
    ('screwgear_ros.ros.launch_support', 'MissingPackages', RuntimeError),
    ('screwgear_ros.ros.param_dump', 'Unwritable', ValueError),
    ('screwgear_ros.sweep.model', 'SweepError', ValueError),
])
def test_the_errors_are_screwgear_errors(module, name, builtin):
    error = getattr(importlib.import_module(module), name)
    assert issubclass(error, ScrewgearError) and issubclass(error, builtin)
