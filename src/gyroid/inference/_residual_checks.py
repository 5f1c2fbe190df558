"""The checks that read a fit's standardised residuals: whiteness (block variances, and the
segments of a gappy log) and outliers. Thresholds and their reasons are in
:mod:`gyroid.inference._checks`' docstring."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from gyroid.inference._check_report import BENCH_REMEDIES, REMEDIES, Check, Severity

WHITENESS_P = 1e-4
WHITENESS_INFLATION = 2.0
OUTLIER_FALSE_ALARM = 0.01
OUTLIER_SHIFT_SD = 1.0
OUTLIER_VARIANCE_SHARE = 0.5


def spike_threshold(n: int) -> float:
    """|z| beyond which white Gaussian noise leaves one of ``n`` samples with probability
    ``OUTLIER_FALSE_ALARM`` (4.8 for n = 6000)."""
    from scipy import stats

    return float(stats.norm.isf(0.5 * OUTLIER_FALSE_ALARM / max(n, 1)))


def without_spikes(z: np.ndarray) -> np.ndarray:
    """Standardised residuals with the samples beyond :func:`spike_threshold` replaced by
    the others' mean and rescaled to the others' variance: a handful of spikes (six handling
    samples in a 24 000-row log) would otherwise set the scale the whiteness test divides by
    and hide the correlation of all the rest."""
    z = np.asarray(z, dtype=float)
    spikes = np.abs(z) > spike_threshold(z.size)
    if not spikes.any() or spikes.all():
        return z
    kept = z[~spikes]
    clean = np.where(spikes, kept.mean(), z)
    return (clean - kept.mean()) / max(float(kept.std()), 1e-300)


def block_variance_ratios(z: np.ndarray, min_blocks: int = 16
                          ) -> list[tuple[int, float, int]]:
    """(m, m * var(block means) / var(z), blocks) for m = 2, 4, 8, ... while at least
    ``min_blocks`` blocks fit. For white ``z`` each ratio is ``chi2(B-1)/(B-1)``."""
    z = np.asarray(z, dtype=float)
    z = z - z.mean()
    var = float(np.mean(z**2))
    out = []
    m = 2
    while var > 0 and z.size // m >= min_blocks:
        b = z.size // m
        means = z[: b * m].reshape(b, m).mean(axis=1)
        out.append((m, float(m * np.var(means, ddof=1) / var), b))
        m *= 2
    return out


def segment_variance_ratio(z: np.ndarray, segments: tuple[tuple[int, int], ...] | None
                           ) -> tuple[float, int] | None:
    """(``sum n_k (mean_k - mean)**2 / ((K - 1) var(z))``, K) over the log's K contiguous
    segments: ``chi2(K-1)/(K-1)`` when ``z`` is white. None for fewer than 8 segments."""
    if segments is None or len(segments) < 8:
        return None
    z = np.asarray(z, dtype=float)
    z = z - z.mean()
    var = float(np.mean(z**2))
    if var <= 0:
        return None
    sizes = np.array([b - a for a, b in segments], dtype=float)
    means = np.array([z[a:b].mean() for a, b in segments])
    k = len(segments)
    return float(np.sum(sizes * means**2) / ((k - 1) * var)), k


def residual_whiteness(residuals: np.ndarray | None, *,
                       segments: tuple[tuple[int, int], ...] | None = None,
                       correlated_noise_modelled: bool = False,
                       remedies: frozenset[str] = BENCH_REMEDIES) -> Check:
    """Block-variance test of standardised residuals (see the module docstring). A severe
    failure advises what this kind of fit can do of ``remedies`` (codes of
    :data:`~gyroid.inference._check_report.REMEDIES`)."""
    from scipy import stats

    if_failed: Severity = "warning" if correlated_noise_modelled else "error"
    if residuals is None or np.asarray(residuals).size < 64:
        return Check("residual_whiteness", True, if_failed, None, WHITENESS_INFLATION,
                     "too few residuals to test for correlation")
    clean = without_spikes(np.asarray(residuals, dtype=float))
    ratios: list[tuple[int | str, float, int]] = list(block_variance_ratios(clean))
    between = segment_variance_ratio(clean, segments)
    if between is not None:
        ratios.append(("segment", *between))
    if not ratios:
        return Check("residual_whiteness", True, if_failed, None, WHITENESS_INFLATION,
                     "too few residuals to test for correlation")
    p_values = np.array([stats.chi2.sf(r * (b - 1), b - 1) for _, r, b in ratios])
    significant = p_values * len(ratios) < WHITENESS_P
    if not significant.any():
        return Check("residual_whiteness", True, if_failed, max(r for _, r, _ in ratios),
                     WHITENESS_INFLATION, "the residuals are consistent with white noise")
    k = max(np.flatnonzero(significant), key=lambda i: ratios[i][1])
    m, inflation, count = ratios[k]
    p = float(min(1.0, p_values[k] * len(ratios)))
    severe = inflation > WHITENESS_INFLATION
    severity: Severity = "error" if severe and not correlated_noise_modelled else "warning"
    blocks = (f"the {count} contiguous segments' means" if m == "segment" else
              f"blocks of {m} samples")
    where = f"{blocks} vary {inflation:.1f}x as much as white noise would (p = {p:.1g})"

    if correlated_noise_modelled:
        advised = ("discrepancy",)
        message = (f"the innovations are still correlated ({where}): an effect is missing or "
                   "the noise model is too simple; look for the missing effect")
    elif not severe:
        advised = ()
        message = (f"the residuals are mildly correlated ({where}); the intervals may be up "
                   f"to {math.sqrt(inflation):.2f}x too narrow")
    else:
        order = (("segment_means", "noise_model", "discrepancy")
                 if m == "segment" else ("noise_model", "discrepancy"))
        advised = tuple(code for code in order if code in remedies)
        what = ("the bias wanders between the log's bursts" if m == "segment" else
                "the residuals are correlated")
        message = (f"{what} ({where}), so the intervals are too narrow; "
                   + ", or ".join(REMEDIES[code] for code in advised))
    return Check("residual_whiteness", False, severity, inflation, WHITENESS_INFLATION,
                 message, advised)


def outliers(residuals: np.ndarray | None, *,
             where: Callable[[int], str] | None = None, name: str = "outliers",
             bias_sd_ratio: float = 1.0, sets_noise_level: bool = True) -> Check:
    """Standardised residuals no Gaussian noise would leave (see the module docstring).
    ``bias_sd_ratio``: the fit's sd of a bias-like coefficient over ``s / sqrt(n)`` of these
    residuals (1 when the fit is of these very samples; larger for a fit of their means,
    whose noise includes wander the samples do not show). ``sets_noise_level``: these
    residuals set the fit's noise level (not so for a fit of their segments' means), so
    outliers with most of their variance are an error."""

    if residuals is None or np.asarray(residuals).size < 16:
        return Check(name, True, "error", None, OUTLIER_SHIFT_SD,
                     "too few residuals to look for outliers")
    z = np.asarray(residuals, dtype=float)
    rows = np.flatnonzero(np.abs(z) > spike_threshold(z.size))
    return outliers_among(z.size, rows, z[rows], float(z @ z), where=where, name=name,
                          bias_sd_ratio=bias_sd_ratio, sets_noise_level=sets_noise_level)


def outliers_among(n: int, rows: np.ndarray, z: np.ndarray, z_sum_sq: float, *,
                   where: Callable[[int], str] | None = None, name: str = "outliers",
                   bias_sd_ratio: float = 1.0, sets_noise_level: bool = True) -> Check:
    """:func:`outliers` of ``n`` standardised residuals given only those that may be beyond
    the threshold (``rows``, 0-based, and their ``z``; any superset of those beyond it) and
    the sum of all ``n`` squares: what a log read as a stream keeps of its samples."""
    if n < 16:
        return Check(name, True, "error", None, OUTLIER_SHIFT_SD,
                     "too few residuals to look for outliers")
    z_max = spike_threshold(n)
    beyond = np.abs(z) > z_max
    rows, z = np.asarray(rows)[beyond], np.asarray(z, dtype=float)[beyond]
    if rows.size == 0:
        return Check(name, True, "error", 0.0, OUTLIER_SHIFT_SD,
                     f"no residual beyond {z_max:.1f} sd")
    shift = float(abs(z.sum()) / math.sqrt(n) / bias_sd_ratio)
    share = float(np.sum(z**2) / z_sum_sq) if sets_noise_level else 0.0
    worst = np.argsort(-np.abs(z))[:3]
    # every one named as the log names it (a block mean's index is not a sample's row)
    named = ", ".join(f"{where(int(rows[i])) if where else f'row {int(rows[i]) + 1}'} at "
                      f"{z[i]:+.0f} sd" for i in worst)
    more = f" and {rows.size - worst.size} more" if rows.size > worst.size else ""
    severity: Severity = ("error" if shift > OUTLIER_SHIFT_SD or share > OUTLIER_VARIANCE_SHARE
                          else "warning")
    if share > OUTLIER_VARIANCE_SHARE:
        consequence = (f"they make {100 * share:.0f} % of the residual variance, so the noise "
                       "level, every interval and every check scaled by it rest on them")
    elif severity == "error":
        consequence = (f"they move a bias-like coefficient by {shift:.1f} sd of its estimate, "
                       "so the answer rests on them")
    else:
        consequence = (f"together they move a bias-like coefficient by {shift:.2f} sd of its "
                       "estimate")
    # Isolated excursions are spikes; neighbours beyond z_max are a stretch the model
    # misses (or correlated noise), which removing rows would hide rather than mend. A
    # bias step shows as the largest excursion with its neighbour beside it, the rest
    # elsewhere (a held-out thermal cycle's: rows at +11 and +6 sd, two more apart).
    in_runs = np.isin(rows - 1, rows) | np.isin(rows + 1, rows)
    structure = bool(in_runs.mean() > 0.5 or in_runs[worst[0]])
    first = f"{where(int(rows[worst[0]])) if where else f'row {int(rows[worst[0]]) + 1}'}"
    advice = ("most come in runs of neighbouring rows: structure the model or the noise model "
              "misses, not spikes; look for the missing effect" if in_runs.mean() > 0.5 else
              f"the largest comes with its neighbour ({first}): a step or a stretch the "
              "model misses, not a spike; look for the missing effect" if structure else
              "remove spikes from the log, or find their cause")
    return Check(name, False, severity, shift, OUTLIER_SHIFT_SD,
                 f"{rows.size} sample(s) lie beyond {z_max:.1f} sd of the model ({named}{more}); "
                 f"{consequence}; {advice}", ("discrepancy",) if structure else ())
