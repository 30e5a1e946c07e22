"""Where the tests find the repository and its checked-in data, from any test folder."""

from pathlib import Path

#: The repository's root (README.md, config/, docs/, launch/, urdf/).
ROOT = Path(__file__).resolve().parents[2]
#: The checked-in bags and scenario files of the tests.
DATA = ROOT / 'test' / 'data'
