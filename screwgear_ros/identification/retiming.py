"""Place a recording's joint_states samples in time, as a recorder left them: each sample
at its own time, whatever the jitter, losses, repeats, rate or gaps, and say what was
found.

A sample's time is its header stamp (the driver's time of the reading) by default, or
its log time (``clock='log'``: when the recorder wrote it). Commands carry no stamp (or
one nobody sets), so they are placed by their log time; header stamps are moved onto
the log clock by the median of (stamp − log time), so samples and commands share one
clock while the samples keep the stamps' spacing. A bag whose stamps are unset (zero)
is placed by its log times, and the notes say so.

Repeated samples (the same header stamp twice: a message logged again) are dropped, the
first kept. Each sample gets its slot on the nominal grid (its time over the period,
rounded; the period refined by a straight line through slots and times), the jitter is
each time's distance from that line, and the empty slots are the lost samples; a hole
of more than :data:`GAP_PERIODS` periods is listed as a gap too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: A hole of more than this many periods is listed as a gap, not only counted as losses.
GAP_PERIODS = 20


@dataclass(frozen=True)
class Placed:
    """Which samples are kept (``order``: indices into the input, in time order), their
    times (ns, on the log clock) and what the placing found."""

    order: np.ndarray
    times: np.ndarray
    period: float                 # median spacing, s
    lost: int
    repeated: int
    gaps: tuple[tuple[float, float], ...]   # (start s from the first sample, length s)
    jitter_rms: float             # s
    jitter_max: float             # s
    offset: float                 # median header stamp − log time, s (0: log clock)
    clock: str                    # 'stamp' or 'log'
    unstamped: bool = False

    def notes(self) -> list[str]:
        """What a report says of the timing, one finding a line."""
        n = len(self.times)
        span = (self.times[-1] - self.times[0]) * 1e-9 if n > 1 else 0.0
        out = [f'{n} samples over {span:.4g} s, median period {self.period * 1e3:.4g} ms '
               f'({1 / self.period:.4g} Hz), placed by their '
               + ('header stamps' if self.clock == 'stamp' else 'log times')]
        if self.unstamped:
            out.append('the header stamps are unset (zero): placed by the log times')
        if self.clock == 'stamp' and self.offset:
            out.append(f'header stamps run {self.offset * 1e3:+.4g} ms from the log times '
                       '(median): moved onto the log clock, where the commands are')
        out.append(f'jitter {self.jitter_rms * 1e6:.1f} µs RMS, at most '
                   f'{self.jitter_max * 1e6:.1f} µs ({100 * self.jitter_max / self.period:.2g} % '
                   'of a period)')
        if self.lost:
            out.append(f'{self.lost} samples lost ({100 * self.lost / (n + self.lost):.3g} %)')
        if self.repeated:
            out.append(f'{self.repeated} repeated samples (same header stamp) dropped')
        for start, length in self.gaps[:5]:
            out.append(f'a gap of {length * 1e3:.4g} ms at {start:.4g} s')
        if len(self.gaps) > 5:
            out.append(f'... and {len(self.gaps) - 5} more gaps')
        return out


def place(stamps: np.ndarray, logs: np.ndarray, clock: str = 'stamp') -> Placed:
    """Place samples with header ``stamps`` and ``logs`` log times (ns, any order).

    Parameters
    ----------
    stamps, logs : ndarray of int
        The header stamps and log times of the samples, ns.
    clock : str
        ``'stamp'`` or ``'log'``: which time places a sample.

    Returns
    -------
    Placed

    Examples
    --------
    >>> import numpy as np
    >>> t = np.array([0, 1, 2, 2, 5, 6]) * 1_000_000
    >>> p = place(t, t + 300_000)
    >>> p.lost, p.repeated, round(p.offset * 1e3, 3), p.times.tolist()[:2]
    (2, 1, -0.3, [300000, 1300000])
    """
    stamps = np.asarray(stamps, dtype=np.int64)
    logs = np.asarray(logs, dtype=np.int64)
    unstamped = clock == 'stamp' and bool(np.all(stamps == 0))
    use_log = clock == 'log' or unstamped
    key = logs if use_log else stamps
    order = np.argsort(key, kind='stable')
    # a repeat is the same message again: its header stamp equals the one before
    by_stamp = stamps[order]
    repeat = np.zeros(len(order), dtype=bool)
    if not unstamped:
        sorted_stamps = np.argsort(by_stamp, kind='stable')
        same = np.diff(by_stamp[sorted_stamps]) == 0
        repeat[sorted_stamps[1:][same]] = True
    order = order[~repeat]
    offset = 0.0 if use_log else float(np.median(stamps[order] - logs[order]))
    times = key[order] - (0 if use_log else round(offset))
    gaps_ns = np.diff(times)
    positive = gaps_ns[gaps_ns > 0]
    period_ns = float(np.median(positive)) if len(positive) else 1.0
    rel = (times - times[0]).astype(np.float64)
    # each sample's slot on the nominal grid; the period refined by a straight line
    # through (slot, time), so a rate a little off its nominal value does not drift
    slot = np.rint(rel / period_ns)
    if len(times) > 2:
        for _ in range(2):
            slope, intercept = np.polyfit(slot, rel, 1)
            period_ns = float(slope)
            slot = np.rint((rel - intercept) / period_ns)
        deviation = rel - np.polyval(np.polyfit(slot, rel, 1), slot)
        rms, top = float(np.sqrt(np.mean(deviation ** 2))), float(np.max(np.abs(deviation)))
    else:
        rms = top = 0.0
    steps = np.maximum(1, np.diff(slot)).astype(np.int64)
    lost = int(np.sum(steps - 1))
    holes = np.flatnonzero(gaps_ns > GAP_PERIODS * period_ns)
    gaps = tuple((float(times[i] - times[0]) * 1e-9, float(gaps_ns[i]) * 1e-9) for i in holes)
    return Placed(order, times, period_ns * 1e-9, lost, int(np.sum(repeat)), gaps,
                  rms * 1e-9, top * 1e-9, offset * 1e-9, 'log' if use_log else 'stamp',
                  unstamped)


__all__ = ['GAP_PERIODS', 'Placed', 'place']
