"""Allan deviation of a rate log and the figures of merit gyro engineers read off it.

The overlapping Allan deviation comes from allantools (a well-kept implementation, so it is
not rewritten here); its 68 % confidence intervals use Greenhall's equivalent degrees of
freedom for white rate noise (alpha = 0). Conventions:

* angle random walk ``N`` (deg/sqrt(h)): the slope -1/2 line ``sigma(tau) = 60 N / sqrt(tau)``
  (sigma in deg/h, tau in s) fitted where the curve has that slope;
* bias instability (deg/h): the level of the first flat stretch of the Allan deviation (a
  flicker floor, or the hump of a Gauss-Markov process), and the averaging time where it
  sits, *resolved* only where that level stands above the angle random walk's line by more
  than the curve's own scatter (the line below the level's 99.9 % chi-square interval):
  at long averaging times a white curve, of few clusters, flattens by chance, and a
  compensated residual of white noise was reported with a bias instability it did not
  have. A burst-sampled log resolves none: its averaging times end within a burst, far
  short of where a gyro's bias instability sits. On a curve that never flattens, its
  minimum, unresolved. (No 0.664 flicker-noise factor: gyroid's simulated Gauss-Markov
  part is scaled so that its Allan-deviation peak equals the stated bias instability.)
"""

from __future__ import annotations

from dataclasses import dataclass

import allantools
import numpy as np

from gyroid.allan._haar import overlapping_haar
from gyroid.errors import GyroidInputError
from gyroid.io._logs import contiguous_segments

#: How sure a bias-instability floor must be to stand above the white line (the several
#: candidate points of a curve's flat stretch each get this interval), and the fewest
#: equivalent degrees of freedom it is read at: the last few averaging times of a log
#: (a quarter of it: 4) rise and fall together, and a white log of 36,000 samples had its
#: last five points climb to 2.3x the white line, beyond their 99.9 % interval.
FLOOR_CONFIDENCE, FLOOR_MIN_EDF = 0.999, 10.0


@dataclass(frozen=True)
class AllanDeviation:
    tau_s: np.ndarray
    adev_deg_h: np.ndarray
    lower_deg_h: np.ndarray  # 68 % interval
    upper_deg_h: np.ndarray
    clusters: np.ndarray
    #: Each point's equivalent degrees of freedom (Greenhall, white rate noise).
    edf: np.ndarray
    segments: int = 1  # contiguous stretches of the log (burst sampling, gaps)

    def figures_of_merit(self) -> dict[str, float | bool | int | str | list]:
        """Angle random walk from the slope -1/2 part before the curve first flattens; bias
        instability as the top of the first flat stretch (a flicker floor, or the hump of a
        Gauss-Markov process, both of slope ~0), of a log of the gyro's noise (of a log
        with anything else in it, :meth:`floor` is what the flat stretch is). Only the
        averaging times the log resolves are used (``tau_range_s``); a curve that never
        flattens there, or whose flat stretch stands no higher above the white line than
        its scatter allows, leaves the bias instability unresolved."""
        arw = self.arw()
        level, tau_s, resolved = self.floor(arw)
        tau = self.tau_s
        out = {"arw_deg_rt_h": arw, "bias_instability_deg_h": level,
               "bias_instability_tau_s": tau_s, "bias_instability_resolved": resolved,
               "tau_range_s": [float(tau[0]), float(tau[-1])], "segments": self.segments}
        if self.segments > 1:
            out["note"] = (f"gappy log: pooled over {self.segments} contiguous segments, "
                           f"averaging times up to {tau[-1]:.3g} s (a quarter of the longest "
                           "segment); longer ones, where a bias instability sits, are not "
                           "resolved")
        return out

    def summary(self, of: str) -> dict[str, float | bool | int | str | list]:
        """What the curve of a log that is not only the gyro's noise shows (``of``: what
        was measured, said in the summary): the angle random walk and the first flat
        stretch as a *floor* (deg/h, at ``floor_tau_s``), not a bias instability: a
        compensated residual's floor is what the compensation leaves (the model's error
        beside the noise), whatever the gyro's flicker."""
        arw = self.arw()
        level, tau_s, resolved = self.floor(arw)
        return {"of": of, "arw_deg_rt_h": arw, "floor_deg_h": level, "floor_tau_s": tau_s,
                "floor_resolved": resolved,
                "tau_range_s": [float(self.tau_s[0]), float(self.tau_s[-1])],
                "segments": self.segments}

    def _slopes(self) -> np.ndarray:
        tau, adev = self.tau_s, self.adev_deg_h
        return (np.gradient(np.log(adev), np.log(tau)) if tau.size > 2
                else np.full(tau.size, -0.5))

    def arw(self) -> float:
        """The angle random walk (deg/sqrt(h)): the slope -1/2 line through the points
        before the curve first flattens (all of those where none has that slope)."""
        slope = self._slopes()
        flat = np.flatnonzero(slope > -0.2)
        head = np.arange(max(int(flat[0]) if flat.size else self.tau_s.size, 1))
        white = head[(slope[head] < -0.35) & (slope[head] > -0.65)]
        pick = white if white.size else head
        return float(np.exp(np.mean(np.log(self.adev_deg_h[pick] * np.sqrt(self.tau_s[pick])
                                           / 60.0))))

    def floor(self, arw: float | None = None) -> tuple[float, float, bool]:
        """The curve's first flat stretch: its top (deg/h), the averaging time there (s),
        and whether it is resolved (a continuous log, and above the angle random walk
        ``arw``'s line by more than the curve's scatter); on a curve that never flattens,
        its minimum, unresolved."""
        arw = self.arw() if arw is None else arw
        slope, adev = self._slopes(), self.adev_deg_h
        flat = np.flatnonzero(slope > -0.2)
        if not flat.size:
            k = int(np.argmin(adev))
            return float(adev[k]), float(self.tau_s[k]), False
        first = end = int(flat[0])
        while end + 1 < adev.size and slope[end + 1] > -0.2:
            end += 1
        k = first + int(np.argmax(adev[first : end + 1]))
        return (float(adev[k]), float(self.tau_s[k]),
                self.segments == 1 and self._above_white(k, arw))

    def _above_white(self, k: int, arw: float) -> bool:
        """Whether the curve at point ``k`` stands above the angle random walk ``arw``'s
        line (deg/sqrt(h)) by more than its scatter: the line below the point's
        :data:`FLOOR_CONFIDENCE` chi-square interval (white noise's degrees of freedom,
        which are fewer than a floor's: the interval is if anything wide), read where the
        curve has :data:`FLOOR_MIN_EDF` degrees of freedom."""
        if self.edf[k] < FLOOR_MIN_EDF:
            return False
        low, _ = allantools.confidence_interval(float(self.adev_deg_h[k]), float(self.edf[k]),
                                                ci=FLOOR_CONFIDENCE)
        return bool(low > 60.0 * arw / np.sqrt(self.tau_s[k]))


def allan_deviation(rate_deg_h: np.ndarray, sample_s: float, *, time_s: np.ndarray | None = None,
                    points_per_decade: int = 8) -> AllanDeviation:
    """Overlapping Allan deviation of a rate (deg/h) with 68 % intervals.

    With ``time_s``, a log with gaps (burst sampling, dropped stretches) is split into
    contiguous segments and the overlapping Allan variance is pooled over them (every
    segment's second differences of phase, never across a gap), for averaging times up to
    a quarter of the longest segment; its degrees of freedom are the segments' summed."""
    rate = np.asarray(rate_deg_h, dtype=float)
    n = rate.size
    if n < 16:
        raise GyroidInputError(f"the Allan deviation needs at least 16 samples, not {n}")
    segments = [(0, n)] if time_s is None else contiguous_segments(time_s)
    if len(segments) == 1:
        return _single_segment(rate, sample_s, points_per_decade)
    return _pooled(rate, sample_s, segments, points_per_decade)


def _tau_grid(m_max: int, points_per_decade: int) -> np.ndarray:
    m_max = max(m_max, 1)
    return np.unique(np.round(np.logspace(0, np.log10(m_max),
                                          int(np.log10(m_max) * points_per_decade) + 1)
                              ).astype(int))


def _pooled(rate, sample_s, segments, points_per_decade) -> AllanDeviation:
    lengths = np.array([b - a for a, b in segments])
    m_grid = _tau_grid(int(lengths.max()) // 4, points_per_decade)
    sums, counts = overlapping_haar(rate, segments, m_grid)
    rows: list[tuple[float, float, float, float, int, float]] = []
    for m, level_sums, level_counts in zip(m_grid, sums, counts, strict=True):
        used = level_counts >= 2  # a stretch of two blocks and a sample more
        count = int(level_counts[used].sum())
        if count == 0:
            continue
        edf = sum(allantools.edf_greenhall(alpha=0, d=2, m=int(m), N=int(n), overlapping=True)
                  for n in lengths[used])
        tau = m * sample_s
        dev = float(np.sqrt(level_sums[used].sum() / (2.0 * count)))
        lo, hi = allantools.confidence_interval(dev, edf)
        rows.append((tau, dev, lo, hi, count, edf))
    taus, adev, lower, upper, clusters, edfs = (np.asarray(column) for column in
                                                (zip(*rows, strict=True) if rows else [()] * 6))
    return AllanDeviation(taus, adev, lower, upper, clusters, edfs, segments=len(segments))


def _single_segment(rate, sample_s, points_per_decade) -> AllanDeviation:
    n = rate.size
    m = _tau_grid(n // 4, points_per_decade)
    taus, adev, _, clusters = allantools.oadev(rate, rate=1.0 / sample_s, data_type="freq",
                                                taus=m * sample_s)
    lower, upper, edfs = [], [], []
    for tau, dev in zip(taus, adev, strict=True):
        edf = allantools.edf_greenhall(alpha=0, d=2, m=int(round(tau / sample_s)), N=n,
                                       overlapping=True)
        lo, hi = allantools.confidence_interval(dev, edf)
        lower.append(lo)
        upper.append(hi)
        edfs.append(edf)
    return AllanDeviation(np.asarray(taus), np.asarray(adev), np.asarray(lower),
                          np.asarray(upper), np.asarray(clusters), np.asarray(edfs))
