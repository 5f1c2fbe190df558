"""Noise levels' priors from a static noise fit of the same gyro at rest (``gyroid noise``):
its posterior read as a log-normal through the 90 % interval, or, for a term the static log
did not resolve, a log-normal whose 95 % quantile is the static fit's upper bound."""

from __future__ import annotations

import math
from collections.abc import Mapping

from gyroid.errors import GyroidInputError
from gyroid.models._priors import LogNormal, Prior
from gyroid.noise._model import NoiseModel

#: A 90 % interval spans 2 x 1.645 sd; a 95 % upper bound sits 1.645 sd above the median.
_Z90 = 1.6448536269514722
#: Below an unresolved term's upper bound, its prior's median (a factor of 10).
UNRESOLVED_BELOW_BOUND = 10.0


def priors_from_noise(terms: Mapping[str, dict], model: NoiseModel) -> dict[str, Prior]:
    """The priors of ``model``'s levels that a static noise fit's ``terms`` give (``gyroid
    noise``'s ``noise.json``; datasheet units, which do not depend on the sample rate): each
    level a term states in those units (:attr:`AbstractNoiseTerm.static_fit`). A
    resolved term whose 90 % interval ``[lo, hi]`` is positive gets ``LogNormal(sqrt(lo hi),
    ln(hi / lo) / 3.29)``, the same interval; a resolved term whose interval reaches zero (a
    mixture with sets of terms without it, such as a Gauss-Markov bump read for the
    flicker floor) gets its interval where present (``ci90_if_present``: ``model``'s level
    stands for that floor whichever term the static log reads it as); a term not resolved
    (or with no such interval) gets a log-normal with its 95 % quantile at the upper bound
    and its median ten times lower.

    On 30 FOG benches given 40 h at rest (``experiments/fog_thermal_bench.py
    --static-hours 40``), reading such a B as a bound held w1 27 times of 30 (one seed 4.8
    sd away); its interval where present, 29 (that seed 3.6 sd)."""
    priors: dict[str, Prior] = {}
    for name, label in model.static_fit.items():
        entry = terms.get(label)
        if not entry:
            raise GyroidInputError(f"the noise fit has no term {label}: run 'gyroid noise' "
                                   "again")
        interval = entry.get("ci90") if entry.get("resolved") else None
        if interval and interval[0] <= 0.0 and entry.get("ci90_if_present"):
            interval = entry["ci90_if_present"]
        if interval and interval[0] > 0.0 and interval[1] > interval[0]:
            low, high = float(interval[0]), float(interval[1])
            priors[name] = LogNormal(math.sqrt(low * high), math.log(high / low) / (2 * _Z90))
            continue
        bound = entry.get("upper_bound_95") or (interval[1] if interval else None)
        if not bound or not math.isfinite(bound) or bound <= 0.0:
            raise GyroidInputError(f"the noise fit's term {label} has neither an interval "
                                   "nor an upper bound: run 'gyroid noise' again")
        priors[name] = LogNormal(bound / UNRESOLVED_BELOW_BOUND,
                                 math.log(UNRESOLVED_BELOW_BOUND) / _Z90)
    return priors
