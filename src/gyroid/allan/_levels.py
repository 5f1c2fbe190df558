"""A noise fit's averaging times against its model: each level alone (``level_fit``), runs
of adjacent levels together (``level_runs``), and the shortest levels a prefilter shapes.

Under the model, level ``l``'s Haar coefficients give ``n_l r_l ~ chi2(n_l)`` (``n_l`` the
coefficients, ``r_l`` the empirical over the model Allan variance), so
``z_l = Phi^-1(F_chi2(n_l r_l))`` is a standard normal score. ``level_fit`` tests each level
alone (two-sided, Bonferroni over the levels). A process the terms lack rarely shows at one
level: it bends the Allan deviation over several adjacent ones, each of which may pass
alone (on the MTi-G run of ``smac_imudata`` four adjacent levels had p 7e-5 to 2e-3 and
passed). ``level_runs`` adds the scores of every run of adjacent levels,
``S = sum z / sqrt(length)`` (standard normal under the model), Bonferroni over the runs.
A misfit is an error when it is significant (p below :data:`LEVEL_P`) and large (the
variance ratio beyond :data:`LEVEL_RATIO` or its inverse: the Allan deviation off by more
than ``sqrt(2)``), a warning when only significant.

A gyro's digital low-pass filter (or decimation) correlates its samples over a few sample
steps; a short filter's deficit below white noise is the term F, but a longer one (or
decimation) shapes the shortest averaging times' Allan variance as no sum of the terms can
(up and down from one level to the next); where those levels hold most of the
coefficients they decide every term (an ADIS16405's 100 Hz output: N read at 1.9
deg/sqrt(h) from the filtered shortest levels, 2.4 from the rest; its z axis's shortest
levels alternate, and the fit of all of them had missed its flicker floor 160-fold).
:func:`drop_prefiltered` leaves out the shortest levels, one at a time, while any of the
:data:`PREFILTER_REACH` shortest remaining ones misfits the fit of every IEEE term (or F for
Q, whichever fits better) significantly (at most :data:`MAX_PREFILTER_LEVELS`). The shortest
level alone was not enough: a log low-passed well below its Nyquist frequency (a phone's,
100 Hz filtered forward and backward and decimated to 10 Hz) has an Allan deviation that
rises over its first levels before white noise's fall, and N with F's deficit, a rise and
fall of its own, crossed the shortest level and missed the next ones (N 0.00002-0.22
deg/sqrt(h) for 2.5, the white noise read as a Gauss-Markov bias at 0.2 s, and a refusal
for the misfit that left at long averaging times).

F's ``1 / tau^2`` is only the leading term of a filter's deficit: for white noise through a
filter whose autocorrelation has first absolute moment ``m`` (s) the Allan variance is
``N^2 / tau (1 - 1.5 m / tau)`` plus terms the filter's shape sets, which fall faster. For
the low-pass filters tried (Butterworth of orders 1-8, one pass or forward and backward;
windowed-sinc FIRs; moving averages and their cascades) those terms were within 2 % of the
Allan variance where the deficit ``1.5 m / tau`` is under 15 %, but up to 14 % where it is
40 %: levels with a deficit of some 30 % passed every test above and lifted N by about 1 %,
as much as its interval (the phone grade of ``experiments/noise_coverage.py``: 21 of 50
intervals held the truth). So F's deficit is read once from the levels kept, and the
levels where it exceeds :data:`PREFILTER_DEFICIT` of the white noise's Allan variance are
left out too; F, known to be there, is then in every set of terms, with the amplitude read
(``HaarStatistics.prefilter_deg``) one more term of its likelihood, log-sd 0.25: left to the
term choice, F was dropped where its deficit is small, and N fell by 2 %; with only its weak
prior, its posterior leaned to zero and N with it. The ``prefilter`` check says which levels
were left out.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.special import ndtri_exp
from scipy.stats import chi2, norm

from gyroid.allan._haar import HaarStatistics
from gyroid.allan._problem import max_likelihood
from gyroid.allan._terms import IEEE_TERMS, shapes
from gyroid.inference._check_report import Check

#: Significance (after Bonferroni) at which a level, or a run of levels, misfits.
LEVEL_P = 1e-4
#: Beyond this variance ratio (or its inverse) a significant misfit is an error.
LEVEL_RATIO = 2.0
#: The most shortest levels a prefilter may take.
MAX_PREFILTER_LEVELS = 4
#: The shortest levels whose misfit says a prefilter shapes them, and the significance
#: (Bonferroni over them) at which it does.
PREFILTER_REACH, PREFILTER_P = 3, 0.01
#: F's deficit below white noise (a fraction of its Allan variance) beyond which a level is
#: left out as well: the filter's own shape is not yet F's there (module docstring).
PREFILTER_DEFICIT = 0.15
_WITH_F = tuple("F" if n == "Q" else n for n in IEEE_TERMS)


def level_scores(stats: HaarStatistics, model_avar: np.ndarray) -> np.ndarray:
    """Each level's standard normal score of its Allan variance under the model's."""
    x = stats.count * stats.avar / model_avar
    below = chi2.logcdf(x, stats.count)
    above = chi2.logsf(x, stats.count)
    return np.where(below < above, ndtri_exp(below), -ndtri_exp(above))


def level_fit(stats: HaarStatistics, model_avar: np.ndarray) -> Check:
    """Each averaging time's Allan variance against the model's (module docstring)."""
    ratio = stats.avar / model_avar
    z = level_scores(stats, model_avar)
    p = np.minimum(1.0, 2.0 * norm.sf(np.abs(z)) * ratio.size)
    size = np.maximum(ratio, 1.0 / ratio)
    significant = p < LEVEL_P
    worst = int(np.argmax(np.where(significant, size, 0.0))) if significant.any() else int(
        np.argmax(size))
    tau = stats.tau_s[worst]
    if not significant.any():
        return Check("level_fit", True, "error", float(size[worst]), LEVEL_RATIO,
                     f"every averaging time's Allan variance fits the model (worst ratio "
                     f"{ratio[worst]:.2f} at {tau:.3g} s)")
    severity = "error" if size[worst] > LEVEL_RATIO else "warning"
    side = "above" if ratio[worst] > 1 else "below"
    return Check("level_fit", False, severity, float(size[worst]), LEVEL_RATIO,
                 f"the Allan variance at {tau:.3g} s is {ratio[worst]:.2f} times the model's "
                 f"({side} it, p {p[worst]:.1g}): a process the noise terms lack, a log that "
                 "is not static, or a temperature drift; cut the log to a static stretch "
                 "or remove the drift first (gyroid compensate)",
                 ("discrepancy",))


def level_runs(stats: HaarStatistics, model_avar: np.ndarray) -> Check:
    """Runs of adjacent averaging times against the model together (module docstring)."""
    z = level_scores(stats, model_avar)
    levels = z.size
    runs = [(a, b) for a in range(levels) for b in range(a + 2, levels + 1)]
    if not runs:
        return Check("level_runs", True, "error", None, LEVEL_RATIO,
                     "too few averaging times for a run of them")
    score = np.array([z[a:b].sum() / np.sqrt(b - a) for a, b in runs])
    p = np.minimum(1.0, 2.0 * norm.sf(np.abs(score)) * len(runs))
    ratio = np.array([(stats.count[a:b] @ stats.avar[a:b]) / (stats.count[a:b] @ model_avar[a:b])
                      for a, b in runs])
    size = np.maximum(ratio, 1.0 / ratio)
    significant = p < LEVEL_P
    worst = int(np.argmax(np.where(significant, size, 0.0))) if significant.any() else int(
        np.argmin(p))
    a, b = runs[worst]
    span = f"{stats.tau_s[a]:.3g} to {stats.tau_s[b - 1]:.3g} s"
    if not significant.any():
        return Check("level_runs", True, "error", float(size[worst]), LEVEL_RATIO,
                     f"no run of adjacent averaging times misfits the model together (the "
                     f"least likely, {span}, p {p[worst]:.2g})")
    side = "above" if ratio[worst] > 1 else "below"
    return Check("level_runs", False, "error" if size[worst] > LEVEL_RATIO else "warning",
                 float(size[worst]), LEVEL_RATIO,
                 f"the Allan variance from {span} ({b - a} adjacent averaging times) lies "
                 f"{side} the model's together, {ratio[worst]:.2f} times it (p "
                 f"{p[worst]:.1g}), though no single one need fail alone: a process the noise "
                 "terms lack bends the Allan deviation there (a bump: a Gauss-Markov bias "
                 "whose correlation time the log does not pin, a vibration, a temperature "
                 "drift); its terms are not a datasheet's", ("discrepancy",))


def drop_prefiltered(stats: HaarStatistics) -> tuple[HaarStatistics, int]:
    """The statistics without the shortest levels a prefilter shapes (module docstring),
    and how many were left out."""
    dropped = 0
    while True:
        fits = {names: max_likelihood(stats, names) for names in (IEEE_TERMS, _WITH_F)}
        if dropped >= MAX_PREFILTER_LEVELS or stats.m.size <= 6:
            break
        names = max(fits, key=lambda n: fits[n][0])
        model = shapes(stats, names) @ np.exp(2.0 * fits[names][1])
        z = level_scores(stats, model)[:PREFILTER_REACH]
        if not 2.0 * norm.sf(np.max(np.abs(z))) * z.size < PREFILTER_P:
            break
        stats, dropped = stats.levels(slice(1, None)), dropped + 1
    # F's deficit falls as 1 / tau: read once, from the fits of the levels kept, it says
    # which levels it still shapes
    deficit, amplitude = _deficit(stats, fits)
    reach_s = stats.tau_s[0] * deficit / PREFILTER_DEFICIT
    while stats.m.size > 6 and stats.tau_s[0] < reach_s:
        stats = replace(stats.levels(slice(1, None)), prefilter_deg=amplitude)
        dropped += 1
    return stats, dropped


def _deficit(stats: HaarStatistics, fits: dict) -> tuple[float, float]:
    """F's deficit at the shortest level over the white noise's Allan variance there, and F
    (deg), in ``fits``' best fit of every IEEE term with F for Q (``max_likelihood`` of
    both sets on ``stats``); no deficit (0) where that fit is no better than Q's, or where
    its deficit is not a filter's (not below the white noise)."""
    (with_f, u), (with_q, _) = fits[_WITH_F], fits[IEEE_TERMS]
    x = np.exp(2.0 * u)
    white, deficit = shapes(stats, ("N", "F"))[0] * x[[_WITH_F.index("N"), _WITH_F.index("F")]]
    if with_f <= with_q or not 0.0 < -deficit < white:
        return 0.0, float("nan")
    return float(-deficit / white), float(np.sqrt(x[_WITH_F.index("F")]))


def prefilter_check(dropped: int, tau0_s: float) -> Check:
    """Which shortest averaging times :func:`drop_prefiltered` left out (a warning)."""
    if dropped == 0:
        return Check("prefilter", True, "warning", 0.0, float(MAX_PREFILTER_LEVELS),
                     "the shortest averaging times fit white noise: no sign of a prefilter")
    below = tau0_s * 2**dropped
    return Check("prefilter", False, "warning", float(dropped), float(MAX_PREFILTER_LEVELS),
                 f"the Allan variance below {below:.3g} s is shaped by correlated samples "
                 "(the gyro's digital low-pass filter or decimation, or a vibration's tone): "
                 "no sum of the noise terms fits it, or a filter's deficit there is more than "
                 f"{100 * PREFILTER_DEFICIT:.0f} % of the white noise's, so those {dropped} "
                 "shortest averaging times were left out and N is read above them")
