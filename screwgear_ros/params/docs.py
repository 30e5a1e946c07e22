"""Documents generated from the parameter declarations: config/paper.yaml and the
README's parameter table.

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
#: The README's lines around its parameter table (the table is what lies between them).
README_START = '<!-- parameters: generated from screwgear_ros/params/table.py'
README_END = '<!-- end of parameters -->'
#: The source tree holding config/ and README.md, as seen from this module.
SOURCE_TREE = Path(__file__).resolve().parents[2]


def paper_yaml() -> str:
    """config/paper.yaml: every parameter with its default, symbol, unit and note,
    under the ``/**`` key (any node name, any namespace)."""
    return '\n'.join([*PAPER_YAML_HEADER, '/**:', '  ros__parameters:',
                      *yaml_lines(TableParams, SimSettings)]) + '\n'


def parameter_table() -> str:
    """The README's parameter table (Markdown)."""
    return '\n'.join(['| parameter | symbol | default | unit | valid | meaning |',
                      '|---|---|---|---|---|---|',
                      *markdown_rows(TableParams), *markdown_rows(SimSettings)]) + '\n'


class SourceTreeError(ScrewgearError, ValueError):
    """The documents to rewrite are not where a source tree has them."""


def readme_with_table(readme: str) -> str:
    """``readme`` with the text between its parameter-table markers replaced by
    :func:`parameter_table` (the markers and everything else kept)."""
    start = readme.find(README_START)
    end = readme.find(README_END)
    if start < 0 or end < start:
        raise SourceTreeError(f'README.md has no parameter table between {README_START!r} '
                              f'and {README_END!r}')
    body = readme.index('\n', start) + 1
    return readme[:body] + parameter_table() + readme[end:]


def write(root: Path = SOURCE_TREE) -> list[Path]:
    """Rewrite ``root``/config/paper.yaml and the parameter table of ``root``/README.md
    from the declarations; the files whose text changed."""
    yaml_path, readme_path = root / 'config' / 'paper.yaml', root / 'README.md'
    for path in (yaml_path, readme_path):
        if not path.is_file():
            raise SourceTreeError(f'{path} is not a file: --write rewrites the documents of a '
                                  'source tree (give it with --root)')
    readme = readme_path.read_text(encoding='utf-8')
    changed = []
    for path, old, new in ((yaml_path, yaml_path.read_text(encoding='utf-8'), paper_yaml()),
                           (readme_path, readme, readme_with_table(readme))):
        if new != old:
            path.write_text(new, encoding='utf-8')
            changed.append(path)
    return changed


def main(args: list[str] | None = None) -> int:
    """Print one document, or rewrite both in place (``--write``)."""
    parser = argparse.ArgumentParser(prog='python -m screwgear_ros.params.docs',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('document', nargs='?', choices=('yaml', 'table'), default='table',
                        help='the document to print (default: the README table)')
    parser.add_argument('--write', action='store_true',
                        help='rewrite config/paper.yaml and the README table in place')
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
        print('config/paper.yaml and the README table are current')
    return 0


__all__ = ['PAPER_YAML_HEADER', 'README_END', 'README_START', 'SOURCE_TREE', 'WRITE_COMMAND',
           'SourceTreeError', 'main', 'paper_yaml', 'parameter_table', 'readme_with_table',
           'write']


if __name__ == '__main__':
    sys.exit(main())
