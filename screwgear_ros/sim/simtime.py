"""Simulation time as the messages stamp it: integer nanoseconds of an integration step.

Simulation time is ``step·dt`` exactly. The plant stamps its outputs with it once per
tick (:attr:`~screwgear_ros.sim.plant.Outputs.time_ns`); a controller that needs the stamp
of a step it was given (the in-process demo law) computes it here, with no numba and no
ROS to import.
"""

from __future__ import annotations

from functools import lru_cache


def sim_time_ns(step: int, dt: float) -> int:
    """Simulation time of integration step ``step``, integer nanoseconds.

    Exact (``step·dt_ns``) when dt is a whole number of nanoseconds, as every
    sensible step is; otherwise rounded to the nearest nanosecond.
    """
    whole = _whole_ns(dt)
    return step * whole if whole is not None else round(step * (dt * 1e9))


@lru_cache(maxsize=16)
def _whole_ns(dt: float) -> int | None:
    """dt in whole nanoseconds, None if it is not one."""
    dt_ns = dt * 1e9
    whole = round(dt_ns)
    return whole if abs(dt_ns - whole) <= 1e-6 * max(1.0, dt_ns) else None


__all__ = ['sim_time_ns']
