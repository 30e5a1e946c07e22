"""Why a recorded run cannot be used: one class per reason, all of them a :class:`BagError`.

The classes derive from :class:`~screwgear_ros.errors.ScrewgearError` and from no
built-in: a tool's error ladder reports a bag it cannot use before it reports a value
or a file error of its own (``replay_run`` turns ``ValueError`` and ``OSError`` from
reading a scenario into its own message), so an unusable bag must not be caught as one.

Examples
--------
>>> from screwgear_ros.bag.errors import BagError, TruncatedBag
>>> TruncatedBag('run.mcap: ends in a chunk').report('check', 'run')
'cannot check run: run.mcap: ends in a chunk (use --allow-truncated to check the readable part)'
>>> isinstance(TruncatedBag('x'), BagError)
True
"""

from __future__ import annotations

from ..errors import ScrewgearError


class BagError(ScrewgearError):
    """A path that cannot be checked, replayed or plotted; the subclass says why."""

    def report(self, verb: str, path: object) -> str:
        """What a command-line tool says after its name.

        Parameters
        ----------
        verb : str
            What the tool could not do ('check', 'plot').
        path : object
            The path it was given.

        Returns
        -------
        str
            'cannot <verb> <path>: why', with the way out for a truncated bag.
        """
        return f'cannot {verb} {path}: {self}'


class NotABag(BagError):
    """The path is no rosbag2 directory with MCAP storage, nor an MCAP file."""


class TruncatedBag(BagError):
    """The recording was killed: the file ends early (readable with allow_truncated)."""

    def report(self, verb: str, path: object) -> str:
        """See :meth:`BagError.report`; adds the --allow-truncated hint."""
        return (f'{super().report(verb, path)} '
                f'(use --allow-truncated to {verb} the readable part)')


class NoParameters(BagError):
    """The bag holds no usable run_parameters message: the model is unknown."""


class InvalidBag(BagError):
    """Damaged or inconsistent: a topic of another type, a message that does not decode,
    samples that disagree with each other."""


class NoData(BagError):
    """Too few output samples to draw (plot_run)."""


__all__ = ['BagError', 'InvalidBag', 'NoData', 'NoParameters', 'NotABag', 'TruncatedBag']
