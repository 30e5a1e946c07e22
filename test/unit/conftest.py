"""Unit tests run in-process: one that starts a process must say so with ``@pytest.mark.ros``
(so that ``pytest -m "not ros"`` stays the fast, process-free subset)."""

from __future__ import annotations

import subprocess

import pytest


@pytest.fixture(autouse=True)
def _no_process_unless_marked(request: pytest.FixtureRequest,
                              monkeypatch: pytest.MonkeyPatch) -> None:
    if request.node.get_closest_marker('ros') is not None:
        return

    class Refused(subprocess.Popen):  # type: ignore[type-arg]
        def __init__(self, *args: object, **kwargs: object) -> None:
            raise AssertionError(f'{request.node.nodeid} starts a process ({args[0]!r}) '
                                 'but is not marked @pytest.mark.ros')

    monkeypatch.setattr(subprocess, 'Popen', Refused)
