"""Documents generated from the parameter declarations: config/paper.yaml and the
parameter table of docs/parameters.md (``python -m screwgear_ros.params.docs [yaml]``)."""

from __future__ import annotations

from .declarations import markdown_rows, yaml_lines
from .table import SimSettings, TableParams

#: The heading lines of config/paper.yaml.
PAPER_YAML_HEADER = (
    "# The paper's worked example (shared/spec/model.md §6) as a ROS 2 parameter file.",
    '# Generated from the parameter declarations in screwgear_ros/params/table.py:',
    '#   python -m screwgear_ros.params.docs yaml > config/paper.yaml',
    '# ros2 run screwgear_ros table_sim --ros-args --params-file config/paper.yaml',
)


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


__all__ = ['PAPER_YAML_HEADER', 'paper_yaml', 'parameter_table']


if __name__ == '__main__':
    import sys
    print(paper_yaml() if sys.argv[1:] == ['yaml'] else parameter_table(), end='')
