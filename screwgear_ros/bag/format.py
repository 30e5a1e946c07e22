"""What makes a directory a rosbag2 bag that ROS 2 Jazzy tools open: the fixed parts.

- message definitions (``ros2msg`` text with its dependencies, as rosbag2 embeds them
  in MCAP schemas) and RIHS01 type hashes, from the ROS 2 Jazzy typestore of
  ``rosbags`` (the same hashes as the ``share/<pkg>/msg/*.json`` of a Jazzy install);
- QoS profiles in rosbag2's metadata version 9 form;
- ``metadata.yaml`` (version 9, storage ``mcap``).
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from functools import cache, lru_cache
from typing import Any

import yaml

#: rosbag2 metadata version written (ROS 2 Jazzy writes 9).
METADATA_VERSION = 9
#: ROS distribution the bags are written for.
ROS_DISTRO = 'jazzy'
#: MCAP profile, schema encoding and message encoding of rosbag2's MCAP storage plugin.
MCAP_PROFILE = 'ros2'
SCHEMA_ENCODING = 'ros2msg'
MESSAGE_ENCODING = 'cdr'
#: MCAP framing that the recorder writes and the bulk reader parses (MCAP specification,
#: little endian): the file's magic, a record's opcode and length, and a Message
#: record's opcode, length and fixed fields (channel id, sequence, log time, publish
#: time), its data following them.
MCAP_MAGIC = b'\x89MCAP0\r\n'
MCAP_RECORD = struct.Struct('<BQ')
MCAP_MESSAGE = struct.Struct('<BQHIQQ')
MCAP_MESSAGE_FIELDS = MCAP_MESSAGE.size - MCAP_RECORD.size     # 22 bytes


@lru_cache(maxsize=1)
def typestore() -> Any:
    """The ROS 2 Jazzy message typestore of ``rosbags`` (definitions, hashes, CDR codec)."""
    from rosbags.typesys import Stores, get_typestore
    return get_typestore(Stores.ROS2_JAZZY)


@cache
def message_definition(msgtype: str) -> tuple[str, str]:
    """(``ros2msg`` definition text with dependencies, RIHS01 hash) of ``pkg/msg/Type``."""
    store = typestore()
    text, _ = store.generate_msgdef(msgtype, ros_version=2)
    return text, store.hash_rihs01(msgtype)


def _duration(sec: int = 0, nsec: int = 0) -> dict[str, int]:
    return {'sec': sec, 'nsec': nsec}


def qos_profile(transient_local: bool = False, depth: int = 10) -> dict[str, Any]:
    """A reliable, keep-last QoS profile in rosbag2 metadata v9 form.

    Durations 0/0 are rmw's 'default' (no deadline, lifespan or lease). A
    transient-local topic keeps one sample, so ``ros2 bag play`` republishes it latched.
    """
    return {
        'history': 'keep_last',
        'depth': 1 if transient_local else depth,
        'reliability': 'reliable',
        'durability': 'transient_local' if transient_local else 'volatile',
        'deadline': _duration(),
        'lifespan': _duration(),
        'liveliness': 'automatic',
        'liveliness_lease_duration': _duration(),
        'avoid_ros_namespace_conventions': False,
    }


def qos_yaml(profiles: Sequence[Mapping[str, Any]]) -> str:
    """The ``offered_qos_profiles`` string of an MCAP channel (what rosbag2 stores there)."""
    return yaml.safe_dump(list(profiles), default_flow_style=False, sort_keys=False).strip()


def metadata_document(mcap_name: str, topics: Sequence[Mapping[str, Any]],
                      counts: Sequence[int], start_ns: int, end_ns: int,
                      custom_data: Mapping[str, str]) -> dict[str, Any]:
    """The ``rosbag2_bagfile_information`` mapping (metadata v9).

    ``topics`` holds ``name``, ``type`` and ``qos`` (a list of v9 profiles) per topic;
    ``counts`` the messages written per topic; times are log times in ns.
    """
    total = int(sum(counts))
    start = int(start_ns) if total else 0
    duration = max(0, int(end_ns) - int(start_ns)) if total else 0
    return {
        'version': METADATA_VERSION,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': duration},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': total,
        'topics_with_message_count': [
            {
                'topic_metadata': {
                    'name': topic['name'],
                    'type': topic['type'],
                    'serialization_format': MESSAGE_ENCODING,
                    'offered_qos_profiles': list(topic['qos']),
                    'type_description_hash': message_definition(topic['type'])[1],
                },
                'message_count': int(count),
            }
            for topic, count in zip(topics, counts, strict=False)
        ],
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [mcap_name],
        'files': [{
            'path': mcap_name,
            'starting_time': {'nanoseconds_since_epoch': start},
            'duration': {'nanoseconds': duration},
            'message_count': total,
        }],
        'custom_data': dict(custom_data),
        'ros_distro': ROS_DISTRO,
    }


def metadata_yaml(document: Mapping[str, Any]) -> str:
    """``metadata.yaml`` text for a ``rosbag2_bagfile_information`` mapping."""
    return yaml.safe_dump({'rosbag2_bagfile_information': dict(document)},
                          default_flow_style=False, sort_keys=False)


__all__ = [
    'MCAP_PROFILE',
    'MESSAGE_ENCODING',
    'METADATA_VERSION',
    'ROS_DISTRO',
    'SCHEMA_ENCODING',
    'message_definition',
    'metadata_document',
    'metadata_yaml',
    'qos_profile',
    'qos_yaml',
    'typestore',
]
