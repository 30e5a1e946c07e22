"""YAML documents read with the line of every node, for messages that name it.

The file formats a user writes by hand (scenario files, sweep files) are composed, not
just loaded, so that every refusal says the file and the line of what is wrong. A
:class:`YamlReader` raises its format's own error type (a ValueError), so each format's
readers and callers see one exception, whatever the reader found.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml

#: The error a reader raises: one of the format's ValueError types, from its message.
ErrorType = Callable[[str], ValueError]
#: What a refusal of deep nesting says: PyYAML composes recursively, so the interpreter's
#: recursion limit (a few hundred levels below its default of 1000) is the real bound.
TOO_DEEP = 'nested deeper than the reader follows (a few hundred levels)'


#: Deepest flow nesting ([ and {) a file may have: PyYAML's scanner slows down
#: quadratically with it (seconds at a thousand levels) before its composer gives up.
MAX_FLOW_DEPTH = 64
_FLOW = re.compile(r'[\[\]{}"\'#\n]')


def flow_depth_line(text: str, limit: int = MAX_FLOW_DEPTH) -> int | None:
    """The line (1-based) where ``text``'s flow collections nest deeper than ``limit``,
    or None; quoted strings and comments are skipped (a cheap scan before the parser)."""
    depth, line, quote = 0, 1, ''
    comment = False
    for match in _FLOW.finditer(text):
        char = match.group()
        if char == '\n':
            line += 1
            comment = False
        elif comment:
            continue
        elif quote:
            if char == quote:
                quote = ''
        elif char in '"\'':
            quote = char
        elif char == '#':
            comment = True
        elif char in '[{':
            depth += 1
            if depth > limit:
                return line
        else:
            depth = max(0, depth - 1)
    return None


def decode(path: Path, data: bytes, error_type: ErrorType = ValueError) -> str:
    """``data`` as UTF-8 text; bytes that are not UTF-8 are the format's error, naming the
    line of the first."""
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as exc:
        line = data.count(b'\n', 0, exc.start) + 1
        raise error_type(f'{path}: line {line}: not UTF-8 text (byte '
                         f'0x{data[exc.start]:02x})') from None


class YamlReader:
    """Values of a composed YAML document, with the line of every node for messages.

    ``root`` is the document's node (None for an empty document). Every check raises
    ``error_type('<path>: line <n>: <what is wrong>')``.
    """

    def __init__(self, path: Path, text: str, error_type: ErrorType = ValueError) -> None:
        self.path = path
        self.error_type = error_type
        deep = flow_depth_line(text)
        if deep is not None:
            raise error_type(f'{path}: line {deep}: [ and {{ nest deeper '
                             f'than {MAX_FLOW_DEPTH} levels')
        try:
            # The reader refuses a control character as the loader is made.
            self._loader = yaml.SafeLoader(text)
            self.root: yaml.Node | None = self._loader.get_single_node()
        except yaml.reader.ReaderError as exc:
            line = text.count('\n', 0, exc.position) + 1
            raise error_type(f'{path}: line {line}: not valid YAML: control character '
                             f'#x{exc.character:04x} is not allowed') from None
        except yaml.YAMLError as exc:
            mark = getattr(exc, 'problem_mark', None)
            where = f'line {mark.line + 1}: ' if mark is not None else ''
            problem = getattr(exc, 'problem', None) or str(exc)
            raise error_type(f'{path}: {where}not valid YAML: {problem}') from None
        except RecursionError:
            raise error_type(f'{path}: not valid YAML: {TOO_DEEP}') from None

    @classmethod
    def open(cls, path: str | Path, error_type: ErrorType = ValueError) -> YamlReader:
        """Read and compose the file at ``path``; a file that cannot be read (missing,
        not UTF-8) is the format's error too."""
        path = Path(path)
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise error_type(f'{path}: cannot read: {exc.strerror or exc}') from None
        return cls(path, decode(path, data, error_type), error_type)

    def error(self, where: yaml.Node | int | None, text: str) -> ValueError:
        """The format's error for ``text`` at a node, or at a line (1-based) of an entry
        read earlier, or at no line (None)."""
        line = where.start_mark.line + 1 if isinstance(where, yaml.Node) else where
        return self.error_type(f'{self.path}: ' + (f'line {line}: ' if line is not None
                                                   else '') + text)

    def value(self, node: yaml.Node) -> Any:
        try:
            return self._loader.construct_object(node, deep=True)
        except RecursionError:
            raise self.error(node, TOO_DEEP) from None
        except yaml.YAMLError as exc:     # a tag or value the safe loader does not build
            mark = getattr(exc, 'problem_mark', None)
            raise self.error(mark.line + 1 if mark is not None else node,
                             f'not valid YAML: {getattr(exc, "problem", None) or exc}') from None

    def mapping(self, node: yaml.Node, what: str) -> dict[str, tuple[yaml.Node, yaml.Node]]:
        """key → (key node, value node) of a mapping node (refused otherwise)."""
        if not isinstance(node, yaml.MappingNode):
            raise self.error(node, f'{what} must be a mapping (key: value)')
        out: dict[str, tuple[yaml.Node, yaml.Node]] = {}
        for key, value in node.value:
            name = self.value(key)
            if not isinstance(name, str):
                raise self.error(key, f'{what}: a key must be a name, not {name!r}')
            if name in out:
                raise self.error(key, f'{what}: {name!r} is given twice')
            out[name] = (key, value)
        return out

    def known(self, entries: dict[str, tuple[yaml.Node, yaml.Node]],
              known: tuple[str, ...], what: str) -> None:
        """Refuse the first key of ``entries`` that is not one of ``known``."""
        for name, (key, _) in entries.items():
            if name not in known:
                raise self.error(key, f'unknown {what} {name!r} (known: {", ".join(known)})')

    def number(self, node: yaml.Node, what: str, low: float | None = None,
               strict: bool = False) -> float:
        """A finite number, at least ``low`` (above it if ``strict``)."""
        value = self.value(node)
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not abs(value) <= sys.float_info.max:      # an int of 400 digits too
            raise self.error(node, f'{what} must be a finite number, not {value!r}')
        if low is not None and (value <= low if strict else value < low):
            raise self.error(node, f'{what} must be {">" if strict else ">="} {low:g}, '
                             f'not {value!r}')
        return float(value)


__all__ = ['MAX_FLOW_DEPTH', 'TOO_DEEP', 'ErrorType', 'YamlReader', 'decode', 'flow_depth_line']
