"""Test-run isolation: DDS on loopback and a ROS_DOMAIN_ID no other run on this machine holds.

Set at import, before any test imports rclpy or starts a node process, so every
process of this run inherits it.
"""

from __future__ import annotations

import fcntl
import os
from typing import IO

_DOMAIN_LOCK: IO[str] | None = None


def _claim_domain_id() -> int:
    """Claim a free ROS_DOMAIN_ID (1…100) with an exclusive lock held for the run."""
    global _DOMAIN_LOCK
    start = os.getpid() % 100
    for k in range(100):
        domain = 1 + (start + k) % 100
        lock = open(f'/tmp/screwgear_ros_domain_{domain}.lock', 'w')
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        _DOMAIN_LOCK = lock
        return domain
    raise RuntimeError('no free ROS_DOMAIN_ID in 1..100 on this machine')


os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['ROS_DOMAIN_ID'] = str(_claim_domain_id())
os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
