"""The predictive check: does a fit's stated uncertainty describe data it has not seen?

Blocked cross-validation in time. The log is cut into ``FOLDS`` contiguous stretches (of
equal row counts, or of whole segments for a log of bursts); each is left out in turn, the
model refitted on the rest (cheaply: the linear-Gaussian path from sufficient statistics per
stretch, otherwise the posterior mode with the left-out rows masked, every fold sharing one
compilation), and the left-out stretch predicted: the means of its ``FINEST`` equal parts,
with their predictive covariance (the training fit's parameter uncertainty carried through
the model, plus the noise model's covariance of those means: white noise ``sigma**2 / m``,
a Gauss-Markov part by its exponential kernel summed exactly).

Calibration is judged at three scales: the parts (``FINEST`` per fold), groups of four, and
whole folds. At each scale the prediction errors are whitened with their covariance within
each fold, ``z = L^-1 (observed - predicted)``, and ``T = sum z**2`` is chi-square with as
many degrees of freedom as means when the fit's bands are right. The check fails when a
scale's p-value times the number of scales (Bonferroni) is below ``PREDICTIVE_P``; its size
is ``T / dof``, the factor by which the variance of a held-out mean exceeds what the fit
states (the bands would have to be ``sqrt(T / dof)`` times wider). Above
``PREDICTIVE_INFLATION`` it is an error (the same size as the whiteness check's), else a
warning. Its false-alarm rate on null logs (white, Gauss-Markov, Student-t noise fitted with
a matching noise model) is measured by ``experiments/predictive_nulls.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from gyroid.inference._check_report import REMEDIES, Check, Severity

#: Stretches left out in turn, and the equal parts each is cut into at the finest scale.
FOLDS = 5
FINEST = 16
#: Family-wise false-alarm rate of the check (over its scales).
PREDICTIVE_P = 1e-3
#: Variance factor of held-out means above which the check is an error.
PREDICTIVE_INFLATION = 2.0


@dataclass(frozen=True)
class Stretches:
    """Rows cut into folds and each fold into parts: ``part`` (n,) the part of every row
    (-1: none), ``fold_of`` (P,) each part's fold, in time order."""

    part: np.ndarray
    fold_of: np.ndarray

    @property
    def n_parts(self) -> int:
        return int(self.fold_of.size)

    def rows_of_fold(self, k: int) -> np.ndarray:
        """Boolean mask of fold ``k``'s rows."""
        return np.isin(self.part, np.flatnonzero(self.fold_of == k))


def stretches(n: int, segments: tuple[tuple[int, int], ...] | None = None, *,
              folds: int = FOLDS, finest: int = FINEST) -> Stretches | None:
    """``n`` rows in time order cut into ``folds`` contiguous folds of about equal row
    counts (whole segments when a log of bursts has at least two per fold, each segment
    then one part when a fold has no more than ``finest``), each fold into ``finest`` parts
    of at least two rows; None when the log is too short to hold out."""
    finest = min(finest, n // (2 * folds))
    if finest < 1:
        return None
    part = np.full(n, -1)
    fold_of = []
    if segments is not None and len(segments) >= 2 * folds:
        bounds = np.array([b for _, b in segments])
        cuts = [0, *(int(np.searchsorted(bounds, n * k / folds)) + 1 for k in range(1, folds)),
                len(segments)]
        for k in range(folds):
            chunk = segments[cuts[k]:cuts[k + 1]]
            if len(chunk) <= finest:  # a part per segment
                for a, b in chunk:
                    part[a:b] = len(fold_of)
                    fold_of.append(k)
                continue
            start, stop = chunk[0][0], chunk[-1][1]
            for a, b in _equal(start, stop, finest):
                part[a:b] = len(fold_of)
                fold_of.append(k)
    else:
        for k, (start, stop) in enumerate(_equal(0, n, folds)):
            for a, b in _equal(start, stop, finest):
                part[a:b] = len(fold_of)
                fold_of.append(k)
    return Stretches(part, np.asarray(fold_of))


def _equal(start: int, stop: int, pieces: int) -> list[tuple[int, int]]:
    edges = np.linspace(start, stop, pieces + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


@dataclass(frozen=True)
class HeldOut:
    """One left-out fold: its parts' observed and predicted means and the predictive
    covariance of their difference (deg/h, (deg/h)^2), and each part's row count."""

    observed: np.ndarray
    predicted: np.ndarray
    covariance: np.ndarray
    counts: np.ndarray
    #: Degrees of freedom of the training fit's noise level (inf when the log gives it).
    noise_dof: float = float("inf")


def _scales(j: int) -> list[int]:
    """Parts merged per mean at each scale: 1, 4, and the whole fold."""
    out = [1]
    if j >= 8:
        out.append(4)
    if j > 1:
        out.append(j)
    return out


def _merged(fold: HeldOut, group: int) -> tuple[np.ndarray, np.ndarray]:
    """The fold's errors and their covariance with parts merged ``group`` at a time (means
    weighted by row counts)."""
    j = fold.counts.size
    labels = np.arange(j) // group
    merge = np.zeros((labels.max() + 1, j))
    merge[labels, np.arange(j)] = fold.counts
    merge /= merge.sum(axis=1, keepdims=True)
    error = merge @ (fold.observed - fold.predicted)
    return error, merge @ fold.covariance @ merge.T


def _fold_statistic(fold: HeldOut, group: int) -> tuple[float, int, float, int]:
    """(T, means, p-value, means outside their 95 % band) of one fold at one scale: its
    errors whitened with their covariance, ``T = sum z**2`` against chi-square (or F when
    the noise level was estimated from ``noise_dof`` degrees of freedom)."""
    from scipy import stats

    error, covariance = _merged(fold, group)
    jitter = 1e-12 * np.trace(covariance) / covariance.shape[0]
    z = np.linalg.solve(np.linalg.cholesky(covariance + jitter * np.eye(error.size)), error)
    total = float(z @ z)
    if np.isfinite(fold.noise_dof):
        p = float(stats.f.sf(total / z.size, z.size, max(fold.noise_dof, 1.0)))
    else:
        p = float(stats.chi2.sf(total, z.size))
    outside = int(np.sum(np.abs(error) > 1.96 * np.sqrt(np.diag(covariance))))
    return total, z.size, p, outside


@dataclass(frozen=True)
class ScaleResult:
    """The check at one scale: ``group`` parts per mean; ``ratio`` the pooled ``T / dof``
    over folds; each fold's own p-value (uncorrected) in ``fold_p``; ``p`` the worst fold's
    times the family size (Bonferroni), that fold and its ``T / dof``; held-out means
    outside their 95 % bands, of ``means``."""

    group: int
    ratio: float
    fold_p: tuple[float, ...]
    p: float
    fold: int
    fold_ratio: float
    outside: int
    means: int


def predictive_scales(folds: list[HeldOut]) -> list[ScaleResult]:
    """The check's statistics at each scale (see the module docstring)."""
    scales = _scales(min(f.counts.size for f in folds))
    family = len(scales) * len(folds)
    results = []
    for group in scales:
        per_fold = [_fold_statistic(fold, group) for fold in folds]
        total, means = sum(r[0] for r in per_fold), sum(r[1] for r in per_fold)
        worst = min(range(len(folds)), key=lambda k: per_fold[k][2])
        t_k, m_k, p_k, _ = per_fold[worst]
        results.append(ScaleResult(group, total / means, tuple(r[2] for r in per_fold),
                                   min(1.0, p_k * family), worst, t_k / m_k,
                                   sum(r[3] for r in per_fold), means))
    return results


def predictive_check(folds: list[HeldOut] | None, *, name: str = "predictive",
                     part_s: float | None = None, why_none: str = "",
                     subject: str | None = None,
                     remedies: tuple[str, ...] = ("noise_model", "segment_means", "discrepancy")
                     ) -> Check:
    """The calibration of held-out means (see the module docstring). Each fold's errors are
    tested on their own (their covariance within the fold is exact; across folds the
    training sets overlap), the family of folds and scales corrected by Bonferroni.
    ``subject`` says what was held out (default: the log's stretches); ``remedies`` what a
    failure advises (codes of :data:`~gyroid.inference._check_report.REMEDIES`)."""
    if not folds:
        return Check(name, True, "error", None, PREDICTIVE_INFLATION,
                     why_none or "the log is too short to hold a stretch out: its bands "
                     "are not tested on data the fit has not seen")
    results = predictive_scales(folds)
    failing = [r for r in results if r.p < PREDICTIVE_P]
    worst = max(failing, key=lambda r: r.fold_ratio) if failing else max(
        results, key=lambda r: r.ratio)
    length = (f" {_duration(part_s * worst.group)}" if part_s else
              f" {worst.group}-part" if worst.group > 1 else "")
    where = (f"{worst.outside} of {worst.means} held-out{length} means fall outside "
             f"their 95 % bands (by chance about {0.05 * worst.means:.1f})")
    subject = subject or f"held out in {len(folds)} stretches"
    if not failing:
        return Check(name, True, "error", worst.ratio, PREDICTIVE_INFLATION,
                     f"{subject}, the fit predicts the data it did not see within its "
                     f"stated bands ({where}; variance ratio {worst.ratio:.2f})")
    inflation = worst.fold_ratio
    stretch = f"in stretch {worst.fold + 1} " if len(folds) > 1 else ""
    severity: Severity = "error" if inflation > PREDICTIVE_INFLATION else "warning"
    return Check(name, False, severity, inflation, PREDICTIVE_INFLATION,
                 f"{subject}, {where}; {stretch}they vary {inflation:.1f}x as much as the "
                 f"fit states (p = {worst.p:.1g}): the stated uncertainty does not describe "
                 f"data the fit has not seen; its bands would have to be "
                 f"{np.sqrt(inflation):.1f}x wider"
                 + ("; " + REMEDIES["noise_terms"] if "noise_terms" in remedies else ""),
                 remedies)


def _duration(seconds: float) -> str:
    if seconds >= 5400:
        return f"{seconds / 3600:.2g} h"
    return f"{seconds / 60:.2g} min" if seconds >= 90 else f"{seconds:.2g} s"


def part_means(values: np.ndarray, part: np.ndarray, n_parts: int) -> np.ndarray:
    """Means of ``values`` over each part (rows of part -1 ignored)."""
    keep = part >= 0
    counts = np.bincount(part[keep], minlength=n_parts)
    return np.bincount(part[keep], values[keep], n_parts) / np.maximum(counts, 1)


def mean_jacobian(predict, u_model: np.ndarray, noise_u: np.ndarray, part: np.ndarray,
                  n_parts: int) -> np.ndarray:
    """d(parts' mean predictions) / d(model coordinates): (P, p), one forward pass per
    coordinate, each reduced to the parts at once (memory O(n))."""
    full = jnp.concatenate([jnp.asarray(u_model), jnp.asarray(noise_u)])
    columns = []
    for i in range(np.size(u_model)):
        tangent = jnp.zeros_like(full).at[i].set(1.0)
        _, derivative = jax.jvp(predict, (full,), (tangent,))
        columns.append(part_means(np.asarray(derivative), part, n_parts))
    return np.column_stack(columns) if columns else np.zeros((n_parts, 0))
