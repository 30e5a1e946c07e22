"""Sweeps: many in-process runs of one scenario over a grid and/or a Monte Carlo draw of
the node's parameters, on this process, a Dask LocalCluster or a Dask cluster
(``sweep`` executable, docs/sweeps.md).

:mod:`.spec` reads sweep files into a :mod:`.model` (the sweep, its axes and runs),
:mod:`.inputs` reads the files a sweep file names,
:mod:`.resolve` resolves and validates every run, :mod:`.worker` runs one run anywhere,
:mod:`.cluster` starts a Dask cluster in the background (:mod:`.early`: while the runs
are validated), :mod:`.engine` places the runs,
:mod:`.progress` runs the pending ones with a progress bar, :mod:`.store` keeps the
results directory, :mod:`.report` writes the results and says what they hold,
:mod:`.summary` draws them. Only :mod:`.cluster` and :mod:`.engine` import Dask, and only
for more than one worker; only :mod:`.store` imports pyarrow.
"""

from .spec import Sweep, SweepError, load_sweep

__all__ = ['Sweep', 'SweepError', 'load_sweep']
