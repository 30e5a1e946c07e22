"""Where the tests find the repository and its checked-in data, from any test folder."""

import ast
from pathlib import Path

#: The repository's root (README.md, config/, docs/, launch/, urdf/).
ROOT = Path(__file__).resolve().parents[2]
#: The checked-in bags and scenario files of the tests.
DATA = ROOT / 'test' / 'data'


def setup_executables() -> list[str]:
    """setup.py's EXECUTABLES (the tools the package installs), read from its text: the one
    list the tests iterate."""
    tree = ast.parse((ROOT / 'setup.py').read_text(encoding='utf-8'))
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == 'EXECUTABLES' for t in node.targets):
            return list(ast.literal_eval(node.value))
    raise AssertionError('setup.py has no EXECUTABLES')
