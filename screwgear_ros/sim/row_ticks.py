"""Runs of ticks that only integrate, many to a compiled call, each tick's outputs kept
as a row: the collaborator behind :meth:`Session.advance
<screwgear_ros.sim.session.Session.advance>` in ``AdvanceMode.ROWS``.

:class:`RowTicks` works on a :class:`~screwgear_ros.sim.plant.Plant` through the plant's
public interface and owns only its scratch rows; the session decides how many ticks may
run this way (no event queued, ``command_timeout`` not due) and keeps its own state.
"""

from __future__ import annotations

import numpy as np

from ..numerics.integrator import OBSERVED
from .plant import OBSERVED_DELTA, OBSERVED_JOINTS, Plant
from .tick import ROW_JOINTS, ROW_STEP, ROW_TE

#: Ticks per compiled call of :meth:`RowTicks.run` (its scratch rows: 0.5 MB).
QUIET_TICKS_PER_CALL = 4096


class RowTicks:
    """Up to n ticks of a running plant, as many calls of
    :meth:`Plant.advance_outputs <screwgear_ros.sim.plant.Plant.advance_outputs>` would
    make them (the same calls, bit for bit), ``QUIET_TICKS_PER_CALL`` to a compiled call
    (:meth:`Plant.advance_ticks <screwgear_ros.sim.plant.Plant.advance_ticks>`).

    Examples
    --------
    >>> from screwgear_ros.params.table import SimSettings, TableParams
    >>> from screwgear_ros.sim.tick import ROW
    >>> settings = SimSettings()
    >>> plant = Plant(TableParams(), settings.dt)
    >>> rows = np.empty((3, ROW))
    >>> RowTicks().run(plant, 3, settings.steps_per_publish, rows, plant.active_path)
    3
    >>> int(rows[2, -1]) == 3 * settings.steps_per_publish == plant.step
    True
    """

    __slots__ = ('_observed',)

    def __init__(self) -> None:
        self._observed: np.ndarray | None = None     # made on first use

    def run(self, plant: Plant, n: int, steps: int, rows: np.ndarray, path: int) -> int:
        """``n`` ticks of ``steps`` steps; row i of ``rows`` (float64, at least n × ROW)
        gets tick i's outputs: θ(3) rad, ω(3) rad/s, effort(3) N·m, the transmission
        error (δ of the active ``path``, which no tick without an event changes) m, and
        the step they are at (exact in float64; a faulted tick's time stands still).

        Stops after a tick in which the plant faulted (:attr:`Plant.fault` says why);
        returns the ticks done (0 on a plant that already stands still)."""
        if self._observed is None:
            self._observed = np.empty((QUIET_TICKS_PER_CALL, OBSERVED))
        scratch = self._observed
        delta = OBSERVED_DELTA[path]
        done = 0
        while done < n and plant.fault is None:
            step0 = plant.step
            k = plant.advance_ticks(min(n - done, QUIET_TICKS_PER_CALL), steps,
                                    scratch)                     # one compiled call
            out, observed = rows[done:done + k], scratch[:k]
            out[:, ROW_JOINTS] = observed[:, OBSERVED_JOINTS]
            out[:, ROW_TE] = observed[:, delta]
            out[:, ROW_STEP] = step0 + steps * np.arange(1, k + 1)
            if plant.fault is not None:      # the last tick faulted: its time stood still
                out[k - 1, ROW_STEP] = plant.step
            done += k
        return done


__all__ = ['QUIET_TICKS_PER_CALL', 'RowTicks']
