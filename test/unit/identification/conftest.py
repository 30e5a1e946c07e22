"""The identification tests' recordings (test/support/identify_truth.py makes them)."""

from __future__ import annotations

from pathlib import Path

import pytest
from identify_truth import copy_topics, record_excitation


@pytest.fixture(scope='session')
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """'node': the excitation as table_sim records it; 'plain': its joint_states and
    cmd_effort alone (sqlite3, no run_parameters)."""
    root = tmp_path_factory.mktemp('identify')
    node = record_excitation(root / 'node')
    plain = copy_topics(node, root / 'plain', ['joint_states', 'cmd_effort'])
    return {'node': node, 'plain': plain, 'root': root}
