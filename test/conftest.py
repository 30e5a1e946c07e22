"""Test-run isolation: DDS on loopback and a ROS_DOMAIN_ID no other run on this machine holds,
and SIGINT that reaches the tools this run starts.

Set at import, before any test imports rclpy or starts a node process, so every
process of this run inherits it.
"""

from __future__ import annotations

import fcntl
import os
import signal
import sys
from pathlib import Path
from typing import IO

_DOMAIN_LOCK: IO[str] | None = None

# The tests' shared helpers (ros_procs, bag_runs, paths, ...), importable from every folder.
sys.path.insert(0, str(Path(__file__).resolve().parent / 'support'))


def _claim_domain_id() -> int:
    """Claim a free ROS_DOMAIN_ID (1…100) with an exclusive lock held for the run."""
    global _DOMAIN_LOCK
    start = os.getpid() % 100
    for k in range(100):
        domain = 1 + (start + k) % 100
        lock = open(f'/tmp/screwgear_ros_domain_{domain}.lock', 'w')  # noqa: SIM115 - held for the session
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        _DOMAIN_LOCK = lock
        return domain
    raise RuntimeError('no free ROS_DOMAIN_ID in 1..100 on this machine')



def _refresh_source_kernels() -> None:
    """Run against the source tree (``python -m pytest`` from the repository, as in an edit
    loop), drop the cached kernels that an edit of another module made stale
    (kernel_cache's docstring says why numba does not); the installed wheel's are
    set-up's."""
    import importlib.util

    from kernel_cache import refresh

    spec = importlib.util.find_spec('screwgear_ros')
    source = Path(__file__).resolve().parents[1] / 'screwgear_ros'
    if spec is not None and spec.origin and Path(spec.origin).resolve().parent == source:
        dropped = refresh(source)
        if dropped:
            print(f'conftest: source tree under test; recompiling the kernels of '
                  f'{len(dropped)} changed module(s): {", ".join(dropped)}', file=sys.stderr)


_refresh_source_kernels()
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['ROS_DOMAIN_ID'] = str(_claim_domain_id())
os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
# A suite started in the background of a shell without job control (`cmd &`, nohup)
# inherits SIGINT ignored, and so would every tool it starts: Python keeps an ignored
# SIGINT ignored, and the Ctrl-C tests would then time out on tools that never saw it.
# A handler here is reset to the default at exec, so the tools get SIGINT as a user's.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
