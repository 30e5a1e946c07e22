"""table_sim's parameters from a ROS 2 parameter file or by name, validated as the node
validates them: what an in-process :class:`~screwgear_ros.inprocess.simulation.Simulation`
is built from."""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from ..errors import ScrewgearError
from ..params.table import SimSettings, TableParams
from ..params.yaml_reader import YamlReader
from .parameter_set import default_values, split_parameters

#: Keys of a ROS 2 parameter file whose ``ros__parameters`` table_sim takes: any node
#: (``/**``) and the node's own name, with or without its leading slash.
NODE_KEYS = ('/**', 'table_sim', '/table_sim', '/**/table_sim')


class ParameterFileError(ScrewgearError, ValueError):
    """A parameter file that cannot be read as table_sim's parameters; says why."""


#: A plain scalar that rcl's parameter file parser reads as a double (strtod) but YAML
#: 1.1 (PyYAML) leaves a string: an exponent without a point in the mantissa (1e-06).
_RCL_DOUBLE = re.compile(r'^[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+$')


def _rcl_value(reader: YamlReader, node: yaml.Node) -> Any:
    """A value as rcl reads it from a parameter file, so one file means the same to
    table_sim and to every tool that reads it here."""
    if isinstance(node, yaml.ScalarNode) and node.style is None and \
            node.tag == 'tag:yaml.org,2002:str' and _RCL_DOUBLE.match(node.value):
        return float(node.value)
    if isinstance(node, yaml.SequenceNode) and all(isinstance(n, yaml.ScalarNode)
                                                   for n in node.value):
        return [_rcl_value(reader, n) for n in node.value]
    return reader.value(node)


def file_values(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The table_sim parameters of a ROS 2 parameter file (``/**:`` or node-name keys
    with ``ros__parameters``, in file order; or a bare mapping of parameter names).

    The one reader of a parameter file: the node's ``--params-file`` semantics, used by
    :meth:`~screwgear_ros.inprocess.simulation.Simulation.from_yaml`, sweeps and the design
    tools alike.

    Raises
    ------
    ParameterFileError
        The file cannot be read, is not UTF-8 or not YAML, nests too deep, has a key that
        is not a name, or holds no parameters for table_sim; the message names the file
        and, where it is known, the line.
    """
    reader = YamlReader.open(Path(path), ParameterFileError)
    root = reader.root
    if root is None:
        return {}
    if not isinstance(root, yaml.MappingNode):
        raise reader.error(root, f'a parameter file is a mapping, not '
                           f'{type(reader.value(root)).__name__}')
    top = reader.mapping(root, 'a parameter file')
    sections = {name: value for name, (_, value) in top.items()
                if isinstance(value, yaml.MappingNode)
                and any(isinstance(key, yaml.ScalarNode) and key.value == 'ros__parameters'
                        for key, _ in value.value)}
    if not sections:
        return {name: _rcl_value(reader, value) for name, (_, value) in top.items()}
    values: dict[str, Any] = {}
    for name, section in sections.items():
        if name not in NODE_KEYS:
            continue
        entries = reader.mapping(section, name)['ros__parameters'][1]
        if reader.value(entries) is None:
            continue
        if not isinstance(entries, yaml.MappingNode):
            raise reader.error(entries, f'{name}: ros__parameters must be a mapping')
        values.update({key: _rcl_value(reader, value) for key, (_, value)
                       in reader.mapping(entries, f'{name}: ros__parameters').items()})
    if not any(name in NODE_KEYS for name in sections):
        raise ParameterFileError(f'{path}: no parameters for table_sim (keys '
                                 f'{", ".join(NODE_KEYS)}); found {", ".join(sections)}')
    return values


def document_values(document: Any, source: str = 'the document') -> dict[str, Any]:
    """The table_sim parameters of a parsed parameter file (see :func:`file_values`);
    ``source`` names it in messages."""
    if document is None:
        return {}
    if not isinstance(document, dict):
        raise ParameterFileError(f'{source}: a parameter file is a mapping, not '
                                 f'{type(document).__name__}')
    sections = {k: v for k, v in document.items()
                if isinstance(v, dict) and 'ros__parameters' in v}
    if not sections:
        return dict(document)
    values: dict[str, Any] = {}
    for key, section in sections.items():
        if key in NODE_KEYS:
            entries = section['ros__parameters'] or {}
            if not isinstance(entries, dict):
                raise ParameterFileError(f'{source}: {key}: ros__parameters must be a mapping')
            values.update(entries)
    if not any(key in NODE_KEYS for key in sections):
        raise ParameterFileError(f'{source}: no parameters for table_sim (keys '
                                 f'{", ".join(NODE_KEYS)}); found {", ".join(map(str, sections))}')
    return values


def load_yaml(path: str | os.PathLike[str]) -> tuple[TableParams, SimSettings]:
    """The validated (TableParams, SimSettings) of a parameter file: :func:`file_values`
    over the node's defaults."""
    return resolve(file_values(path))


def resolve(values: Mapping[str, Any] | None = None, **overrides: Any) -> tuple[
        TableParams, SimSettings]:
    """The node's defaults, then ``values``, then ``overrides``, by parameter name,
    validated as the node validates them (ParameterError naming the parameter)."""
    return split_parameters({**default_values(), **dict(values or {}), **overrides})


__all__ = ['NODE_KEYS', 'ParameterFileError', 'default_values', 'document_values', 'file_values',
           'load_yaml', 'resolve', 'split_parameters']
