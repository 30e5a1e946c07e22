"""physics.model, split by job, still answers every old name for one release: the very
object of its new module, with a DeprecationWarning naming that module."""

from __future__ import annotations

import importlib

import pytest

from screwgear_ros.physics import drive, equilibrium, mesh, motion, packed


@pytest.mark.parametrize('name, module', [
    ('pack', packed), ('N_STATE', packed), ('mesh_force', mesh), ('ContactBranch', mesh),
    ('drive_torques', drive), ('active_path', drive), ('motion', motion), ('rhs', motion),
    ('effort_and_meshes', motion), ('equilibrium_state', equilibrium),
    ('EquilibriumNotFound', equilibrium),
])
def test_an_old_name_is_the_new_object_with_a_warning(name, module):
    old = importlib.import_module('screwgear_ros.physics.model')
    with pytest.warns(DeprecationWarning, match=f'{module.__name__}.{name}'):
        assert getattr(old, name) is getattr(module, name)


def test_an_unknown_name_is_an_attribute_error():
    old = importlib.import_module('screwgear_ros.physics.model')
    with pytest.raises(AttributeError):
        old.no_such_name    # noqa: B018


def test_every_new_module_name_is_reachable_from_the_old_path():
    old = importlib.import_module('screwgear_ros.physics.model')
    for module in (packed, mesh, drive, motion, equilibrium):
        for name in module.__all__:
            assert old.MOVED_NAMES[name] == module.__name__.rsplit('.', 1)[1], name
