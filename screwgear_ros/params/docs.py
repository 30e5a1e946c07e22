"""Documents generated from the parameter declarations: config/paper.yaml and the
parameter table of docs/parameters.md.

``python -m screwgear_ros.params.docs --write`` rewrites both in place in the source tree
(after a parameter is added or changed); ``python -m screwgear_ros.params.docs yaml`` and
``... table`` print one of them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import ScrewgearError
from .declarations import markdown_rows, yaml_lines
from .table import SimSettings, TableParams

#: The command that writes both documents (named in each, so a reader finds it).
WRITE_COMMAND = 'python -m screwgear_ros.params.docs --write'
#: The heading lines of config/paper.yaml.
PAPER_YAML_HEADER = (
    "# The paper's worked example (shared/spec/model.md §6) as a ROS 2 parameter file.",
    '# Generated from the parameter declarations in screwgear_ros/params/table.py:',
    f'#   {WRITE_COMMAND}',
    '# ros2 run screwgear_ros table_sim --ros-args --params-file config/paper.yaml',
)
#: The document that holds the parameter table, relative to the source tree.
TABLE_DOCUMENT = Path('docs') / 'parameters.md'
#: Its lines around the parameter table (the table is what lies between them).
TABLE_START = '<!-- parameters: generated from screwgear_ros/params/table.py'
TABLE_END = '<!-- end of parameters -->'
#: The source tree holding config/ and docs/, as seen from this module.
SOURCE_TREE = Path(__file__).resolve().parents[2]


def paper_yaml() -> str:
    """config/paper.yaml: every parameter with its default, symbol, unit and note,
    under the ``/**`` key (any node name, any namespace)."""
    return '\n'.join([*PAPER_YAML_HEADER, '/**:', '  ros__parameters:',
                      *yaml_lines(TableParams, SimSettings)]) + '\n'


def parameter_table() -> str:
    """The parameter table of docs/parameters.md (Markdown)."""
    return '\n'.join(['| parameter | symbol | default | unit | valid | meaning |',
                      '|---|---|---|---|---|---|',
                      *markdown_rows(TableParams), *markdown_rows(SimSettings)]) + '\n'


class SourceTreeError(ScrewgearError, ValueError):
    """The documents to rewrite are not where a source tree has them."""


def with_table(document: str) -> str:
    """``document`` (docs/parameters.md's text) with the text between its parameter-table
    markers replaced by :func:`parameter_table` (the markers and everything else kept)."""
    start = document.find(TABLE_START)
    end = document.find(TABLE_END)
    if start < 0 or end < start:
        raise SourceTreeError(f'{TABLE_DOCUMENT} has no parameter table between '
                              f'{TABLE_START!r} and {TABLE_END!r}')
    body = document.index('\n', start) + 1
    return document[:body] + parameter_table() + document[end:]


def write(root: Path = SOURCE_TREE) -> list[Path]:
    """Rewrite ``root``/config/paper.yaml and the parameter table of
    ``root``/docs/parameters.md from the declarations; the files whose text changed."""
    yaml_path, table_path = root / 'config' / 'paper.yaml', root / TABLE_DOCUMENT
    for path in (yaml_path, table_path):
        if not path.is_file():
            raise SourceTreeError(f'{path} is not a file: --write rewrites the documents of a '
                                  'source tree (give it with --root)')
    document = table_path.read_text(encoding='utf-8')
    changed = []
    for path, old, new in ((yaml_path, yaml_path.read_text(encoding='utf-8'), paper_yaml()),
                           (table_path, document, with_table(document))):
        if new != old:
            path.write_text(new, encoding='utf-8')
            changed.append(path)
    return changed


def main(args: list[str] | None = None) -> int:
    """Print one document, or rewrite both in place (``--write``)."""
    parser = argparse.ArgumentParser(prog='python -m screwgear_ros.params.docs',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('document', nargs='?', choices=('yaml', 'table'), default='table',
                        help='the document to print (default: the parameter table)')
    parser.add_argument('--write', action='store_true',
                        help='rewrite config/paper.yaml and the table of docs/parameters.md '
                        'in place')
    parser.add_argument('--root', type=Path, default=SOURCE_TREE,
                        help='the source tree to write in (default: %(default)s)')
    options = parser.parse_args(args)
    if not options.write:
        print(paper_yaml() if options.document == 'yaml' else parameter_table(), end='')
        return 0
    try:
        changed = write(options.root)
    except (SourceTreeError, OSError) as error:
        print(f'error: {error}', file=sys.stderr)
        return 2
    for path in changed:
        print(f'rewrote {path}')
    if not changed:
        print('config/paper.yaml and the table of docs/parameters.md are current')
    return 0


__all__ = ['PAPER_YAML_HEADER', 'SOURCE_TREE', 'TABLE_DOCUMENT', 'TABLE_END', 'TABLE_START',
           'WRITE_COMMAND', 'SourceTreeError', 'main', 'paper_yaml', 'parameter_table',
           'with_table', 'write']


if __name__ == '__main__':
    sys.exit(main())
