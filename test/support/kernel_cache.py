"""Numba's on-disk cache, kept true when the tests run against the source tree.

numba checks a cached kernel against the file that defines it only: a kernel in
``numerics/integrator.py`` compiled with ``physics/mesh.py``'s functions inlined, or with
``physics/packed.py``'s index constants frozen in, keeps its old machine code when only
those files change. The installed wheel never meets this (``scripts/setup_venv.sh`` drops
every cached kernel on a reinstall); the source tree, where ``pytest -m "not ros"`` runs
during an edit, does. :func:`refresh` drops the compiled code of exactly the modules whose
own source, or the source of a project module they import (transitively), changed since
it was compiled, so an edit recompiles only the kernels it can have changed.
"""

from __future__ import annotations

import ast
import hashlib
import json
from pathlib import Path

#: The stamps: for each module, the digest of the sources its compiled code was made from.
STAMPS = '__pycache__/screwgear_kernel_sources.json'


def _module_file(package: Path, dotted: str) -> Path | None:
    """The file of ``screwgear_ros.<dotted>`` below ``package``, if it is a module."""
    base = package.joinpath(*dotted.split('.')) if dotted else package
    for candidate in (base.with_suffix('.py'), base / '__init__.py'):
        if candidate.is_file():
            return candidate
    return None


def _imports(package: Path, path: Path) -> set[Path]:
    """The project modules that ``path`` imports, lazy and TYPE_CHECKING imports included
    (a kernel's globals can come from any of them)."""
    here = path.relative_to(package).with_suffix('').parts
    if here[-1] == '__init__':
        here = here[:-1]
    found: set[Path] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
        names: list[str] = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parent = here[:len(here) - node.level + (1 if path.name == '__init__.py' else 0)]
                prefix = '.'.join(parent + tuple(filter(None, (node.module or '').split('.'))))
            elif node.module and node.module.split('.')[0] == package.name:
                prefix = '.'.join(node.module.split('.')[1:])
            else:
                continue
            names = [prefix] + [f'{prefix}.{a.name}'.lstrip('.') for a in node.names]
        elif isinstance(node, ast.Import):
            names = ['.'.join(a.name.split('.')[1:]) for a in node.names
                     if a.name.split('.')[0] == package.name]
        for name in names:
            module = _module_file(package, name.strip('.'))
            if module is not None and module != path:
                found.add(module)
    return found


def digests(package: Path) -> dict[str, str]:
    """For each module of ``package`` (relative path), a digest of its source and of every
    project module it imports, transitively."""
    modules = sorted(package.rglob('*.py'))
    edges = {m: _imports(package, m) for m in modules}
    content = {m: hashlib.sha256(m.read_bytes()).hexdigest() for m in modules}
    out: dict[str, str] = {}
    for module in modules:
        seen, todo = {module}, [module]
        while todo:
            for nxt in edges.get(todo.pop(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        closure = hashlib.sha256()
        for m in sorted(seen):
            closure.update(f'{m.relative_to(package)}:{content[m]}\n'.encode())
        out[str(module.relative_to(package))] = closure.hexdigest()
    return out


def _cached(package: Path, module: str) -> list[Path]:
    """The numba cache files (index and code) of ``module``'s kernels."""
    path = package / module
    return [*path.parent.glob(f'__pycache__/{path.stem}.*.nbi'),
            *path.parent.glob(f'__pycache__/{path.stem}.*.nbc')]


def refresh(package: Path) -> list[str]:
    """Drop the cached kernels of every module of ``package`` whose sources (its own and its
    project imports') differ from those they were compiled from, or are not known; stamp
    the current sources. Returns the modules whose kernels were dropped."""
    stamps_file = package / STAMPS
    try:
        stamps = json.loads(stamps_file.read_text(encoding='utf-8'))
    except (OSError, ValueError):
        stamps = {}
    now = digests(package)
    dropped = []
    for module, digest in now.items():
        files = _cached(package, module)
        if files and stamps.get(module) != digest:
            for f in files:
                f.unlink(missing_ok=True)
            dropped.append(module)
    stamps_file.parent.mkdir(exist_ok=True)
    stamps_file.write_text(json.dumps(now, indent=0, sort_keys=True), encoding='utf-8')
    return dropped
