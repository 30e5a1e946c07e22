"""What of the machine this process may use: its cores (a sweep's workers and
check_run's forked computations are counted against them)."""

from __future__ import annotations

import os


def cores() -> int:
    """The cores this process may run on (its affinity; the machine's count where the
    platform has no affinity)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


__all__ = ['cores']
