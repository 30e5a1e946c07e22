"""Find a bag's files and scan them, whatever rosbag2 storage wrote them.

One MCAP file without file or message compression (what table_sim records, and what
``ros2 bag record -s mcap`` writes with or without chunk compression or a storage preset)
takes the fast path, :func:`screwgear_ros.bag.mcap_scan.scan`. Everything else rosbag2
writes goes through ``rosbags``' rosbag2 reader: sqlite3 (plain, or with zstd file or
message compression), MCAP with file or message compression, and bags split across
files. Either way the result is the same scan (channels, and the messages of the topics
the readers use, in the order the bag holds them: the file's for MCAP, rosbags' for the
rest, which is the order of their log times), so the readers above never know which
storage it was. A bag neither can open is a :class:`BagError` saying why.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import BagError, InvalidBag, NotABag
from .mcap_scan import _Scan, scan

#: The storages rosbag2 writes (its default plugins) and the compressor it has.
STORAGES = ('mcap', 'sqlite3')
COMPRESSORS = ('zstd',)
_SUFFIXES = {'.mcap': 'mcap', '.db3': 'sqlite3'}


@dataclass(frozen=True)
class BagLayout:
    """Where a bag's messages are: the directory, its storage files, and how to read them."""

    path: Path                  # the bag directory (a lone file's directory)
    files: tuple[Path, ...]     # the storage files, in order
    storage: str                # 'mcap' or 'sqlite3'
    compression: str = ''       # '' or 'file' or 'message' (zstd)
    directory: bool = True      # read as a rosbag2 directory (metadata.yaml)

    @property
    def fast(self) -> bool:
        """Whether :func:`scan` reads it: one plain MCAP file."""
        return self.storage == 'mcap' and not self.compression and len(self.files) == 1


def _metadata(meta: Path) -> dict[str, Any]:
    try:
        document = yaml.safe_load(meta.read_bytes().decode('utf-8'))
        info = document.get('rosbag2_bagfile_information') if isinstance(document,
                                                                          dict) else None
        if not isinstance(info, dict) or not isinstance(info.get('relative_file_paths', []),
                                                        list):
            raise TypeError('rosbag2_bagfile_information is not a mapping with a list of '
                            'relative_file_paths')
        return info
    except (yaml.YAMLError, TypeError, AttributeError, UnicodeDecodeError, OSError) as exc:
        raise NotABag(f'{meta}: not a rosbag2 metadata file ({exc})') from None


def locate(path: str | Path) -> BagLayout:
    """The layout of a rosbag2 directory, or of a lone .mcap or .db3 file."""
    path = Path(path)
    if not path.exists():
        raise NotABag(f'{path}: no such file or directory')
    if path.is_file():
        if path.suffix not in _SUFFIXES:
            raise NotABag(f'{path} is neither a rosbag2 directory nor an .mcap or .db3 file')
        return BagLayout(path.parent, (path,), _SUFFIXES[path.suffix], directory=False)
    meta = path / 'metadata.yaml'
    if not meta.is_file():
        found = sorted(p for p in path.iterdir() if p.suffix in _SUFFIXES and p.is_file())
        if len(found) == 1:
            return BagLayout(path, (found[0],), _SUFFIXES[found[0].suffix], directory=False)
        if not found:
            raise NotABag(f'{path} is not a rosbag2 directory: no metadata.yaml naming a '
                          'storage file, and no .mcap or .db3 file in it')
        raise InvalidBag(f'{path} has no metadata.yaml and {len(found)} storage files: '
                         f'`ros2 bag reindex {path}` writes the metadata that orders them')
    info = _metadata(meta)
    storage = info.get('storage_identifier')
    if storage not in STORAGES:
        raise NotABag(f'{path}: storage {storage!r} is not one of rosbag2\'s '
                      f'({", ".join(STORAGES)}): no reader for it')
    mode = str(info.get('compression_mode') or '').lower()
    mode = '' if mode == 'none' else mode
    if mode and mode not in ('file', 'message'):
        raise NotABag(f'{path}: compression mode {mode!r} is not one rosbag2 writes')
    if mode and info.get('compression_format') not in COMPRESSORS:
        raise NotABag(f'{path}: its files are compressed with '
                      f'{info.get("compression_format")!r}, and no decompressor for it is '
                      f'available (only {", ".join(COMPRESSORS)})')
    files = tuple(path / Path(str(p)).name for p in info.get('relative_file_paths', []))
    missing = [f.name for f in files if not f.is_file()]
    if missing or not files:
        raise NotABag(f'{path}: metadata.yaml names {"no storage file" if not files else ""}'
                      f'{", ".join(missing)}{" which is not there" if missing else ""}')
    return BagLayout(path, files, storage, mode)


def scan_bag(layout: BagLayout, status: dict[str, Any]) -> _Scan:
    """The bag's channels and kept messages (:func:`scan` for the fast path)."""
    if layout.fast:
        return scan(layout.files[0], status)
    return _scan_rosbags(layout)


def _scan_rosbags(layout: BagLayout) -> _Scan:
    """What :func:`scan` gives, read by ``rosbags`` (any storage, compression, split)."""
    from rosbags.rosbag2 import Reader
    result = _Scan()
    target = layout.path if layout.directory else layout.files[0]
    try:
        with Reader(target) as reader:
            for connection in reader.connections:
                result.schemas[connection.id] = connection.msgtype
                result.channels[connection.id] = (connection.topic, connection.msgtype)
            for connection, log_time, data in reader.messages():
                result._keep(connection.id, np.array([result.count]),
                             np.array([log_time], dtype=np.int64), [bytes(data)])
                result.count += 1
    except BagError:
        raise
    except Exception as exc:  # noqa: BLE001 - rosbags', sqlite3's and zstd's errors alike
        raise InvalidBag(f'{target}: its {layout.storage} storage'
                         f'{" (" + layout.compression + " compression)" if layout.compression else ""}'
                         f' cannot be read: {exc or type(exc).__name__}') from None
    return result


__all__ = ['COMPRESSORS', 'STORAGES', 'BagLayout', 'locate', 'scan_bag']
