"""The public API (everything ``screwgear_ros.__all__`` exports) documents itself in
numpydoc form, and its examples run: each is executed here with doctest."""

from __future__ import annotations

import dataclasses
import doctest
import inspect
import sys

import pytest

import screwgear_ros

PUBLIC = sorted(n for n in screwgear_ros.__all__ if n != '__version__')


def _doc(obj: object) -> str:
    return inspect.getdoc(obj) or ''


@pytest.mark.parametrize('name', PUBLIC)
def test_every_public_name_has_a_numpydoc_docstring_with_examples(name):
    obj = getattr(screwgear_ros, name)
    doc = _doc(obj)
    assert 'Examples\n--------' in doc, f'{name}: no Examples section'
    # a dataclass's fields are its parameters, each documented where it is declared
    if inspect.isfunction(obj) or (inspect.isclass(obj) and not issubclass(obj, Exception)
                                   and '__init__' in vars(obj)
                                   and not dataclasses.is_dataclass(obj)):
        assert 'Parameters\n----------' in doc, f'{name}: no Parameters section'


@pytest.mark.parametrize('name', PUBLIC)
def test_the_public_methods_say_what_they_take_and_give(name):
    obj = getattr(screwgear_ros, name)
    if not inspect.isclass(obj):
        return
    missing = []
    for attr, value in vars(obj).items():
        if attr.startswith('_'):
            continue
        func = value.__func__ if isinstance(value, (classmethod, staticmethod)) else value
        if not inspect.isfunction(func):
            continue
        doc = _doc(func)
        takes = len(inspect.signature(func).parameters) > (0 if isinstance(value, staticmethod)
                                                             else 1)
        if takes and 'Parameters\n----------' not in doc:
            missing.append(f'{attr}: Parameters')
        if 'Returns\n-------' not in doc and inspect.signature(func).return_annotation not in (
                'None', None, inspect.Signature.empty):
            missing.append(f'{attr}: Returns')
    assert not missing, f'{name}: ' + ', '.join(missing)


@pytest.mark.parametrize('name', PUBLIC)
def test_the_examples_run(name):
    obj = getattr(screwgear_ros, name)
    module = sys.modules[obj.__module__]
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = [t for t in finder.find(obj, name, module=module, globs={}) if t.examples]
    for test in tests:
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f'{name}: {result.failed} example(s) failed (see the output)'
