"""A second reader of a recording's messages, on ``mcap``'s own stream reader: what the
tests compare the package's reader and writer with."""

from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mcap.exceptions import InvalidMagic, McapError
from mcap.records import Channel, DataEnd, Footer, Message, Schema
from mcap.stream_reader import StreamReader

from screwgear_ros.bag.errors import NotABag


def iter_messages(mcap_path: Path, status: dict[str, Any]) -> Iterator[tuple[str, str, int, bytes]]:
    """(topic, type, log time ns, CDR bytes) of the data section, in file order.

    Stops quietly where the file stops making sense and records why in
    ``status['truncated']`` (a killed writer leaves no footer and a partial chunk).
    """
    schemas: dict[int, str] = {}
    channels: dict[int, tuple[str, str]] = {}
    with open(mcap_path, 'rb') as stream:
        reader = StreamReader(stream, record_size_limit=1 << 30)
        records = reader.records
        while True:
            try:
                record = next(records)
            except StopIteration:
                break
            except InvalidMagic:
                if stream.tell() <= 16:
                    raise NotABag(f'{mcap_path} is not an MCAP file') from None
                status['truncated'] = f'{mcap_path.name} has no valid end magic'
                break
            except (McapError, struct.error, ValueError, MemoryError) as exc:
                status['truncated'] = (f'{mcap_path.name} ends without its summary after '
                                       f'{stream.tell()} bytes ({type(exc).__name__}): the '
                                       'recording was not closed (killed?)')
                break
            except Exception as exc:  # noqa: BLE001 - zstd or CRC errors in a cut chunk
                status['truncated'] = (f'{mcap_path.name} is damaged after {stream.tell()} '
                                       f'bytes: {type(exc).__name__}: {exc}')
                break
            if isinstance(record, Message):
                topic, msgtype = channels[record.channel_id]
                yield topic, msgtype, record.log_time, record.data
            elif isinstance(record, Schema):
                schemas[record.id] = record.name
            elif isinstance(record, Channel):
                channels[record.id] = (record.topic, schemas.get(record.schema_id, ''))
            elif isinstance(record, (DataEnd, Footer)):
                break      # the summary after it repeats the data section (unchecked)
