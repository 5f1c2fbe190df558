"""Paper A's magnetic table pooled: is the test-to-test spread of a device's coefficients
real run-to-run variation, or the noise of each test?

The paper prints two tests per device and no uncertainties. What is assumed: each printed
coefficient is the paper's estimator ``K = (mean at +300 uT - mean at -300 uT) / 6`` of
180 s means of a FOG whose angle random walk is ``ASSUMED_ARW`` (gyroid's simulated FOG;
the paper gives no noise figure), so its sd is ``sqrt(2) * ARW * 60 / sqrt(180 s) / 6``
deg/h per 100 uT (0.0053 at 0.005 deg/sqrt(h)). Bias instability or a slow wander during
the 50 min of a sweep would make it larger; the answer therefore also gives, per
coefficient, the within-test sd above which the two tests would agree (``s_star``: the
difference at the 5 % level of a two-sided test).

Per device, the two tests are pooled with :func:`gyroid.pool._fit.pool_estimates`:
population means ~ Normal(0, 1) deg/h per 100 uT (the paper's largest coefficient is
0.58), between-test sds half-normal(0.5).
"""

from __future__ import annotations

import math

import numpy as np

from gyroid.inference._nuts import Nuts
from gyroid.io._paper_tables import paper_a_magnetic_coefficients
from gyroid.models._priors import Normal
from gyroid.pool._fit import pool_estimates
from gyroid.pool._result import PoolFit

#: Angle random walk assumed for paper A's FOG, deg/sqrt(h).
ASSUMED_ARW_DEG_RT_H = 0.005
#: The paper's dwell at each field value, s, and the span of its estimator, in H0 units.
DWELL_S = 180.0
SPAN_H0 = 6.0
AXES = ("wx", "wy", "wz")
_Z975 = 1.959964


def within_test_sd(arw_deg_rt_h: float = ASSUMED_ARW_DEG_RT_H, dwell_s: float = DWELL_S
                   ) -> float:
    """Sd of the paper's K estimator under white noise, deg/h per 100 uT."""
    mean_sd = arw_deg_rt_h * 60.0 / math.sqrt(dwell_s)
    return math.sqrt(2.0) * mean_sd / SPAN_H0


def magnetic_repeatability(*, seed: int = 0, sampler: Nuts | None = None
                           ) -> dict[int, PoolFit]:
    """Each device's two tests pooled (device number -> result)."""
    table = paper_a_magnetic_coefficients()
    s = within_test_sd()
    out = {}
    for device in sorted({d for d, _ in table}):
        tests = sorted(t for d, t in table if d == device)
        estimates = np.array([[table[(device, t)][a] for a in AXES] for t in tests])
        out[device] = pool_estimates(
            AXES, tuple(f"test {t}" for t in tests), estimates, np.full(estimates.shape, s),
            mean_priors=[Normal(0.0, 1.0)] * len(AXES), spread_scales=np.full(len(AXES), 0.5),
            seed=seed, sampler=sampler)
    return out


def repeatability_json(results: dict[int, PoolFit]) -> dict:
    """``reproduce.json``'s ``paper_a.magnetic_repeatability``."""
    s = within_test_sd()
    devices = {}
    for device, result in results.items():
        record = result.to_json()
        axes = {}
        for k, name in enumerate(AXES):
            x = result.own_mean[:, k]
            h = result.heterogeneity[name]
            difference = float(abs(x[1] - x[0]))
            s_star = difference / (_Z975 * math.sqrt(2.0))
            axes[name] = {
                "tests": [float(v) for v in x],
                "difference": difference,
                "Q": h.q, "p_value": h.p_value,
                "s_star": s_star,
                "between_test_sd": {key: record["between_run_sd"][name][key]
                                    for key in ("mean", "sd", "ci95")},
                "population": record["population"][name],
                "new_test_predictive": record["new_run_predictive"][name],
                "verdict": (f"the tests differ by {difference:.3g}, "
                            f"{difference / (math.sqrt(2.0) * s):.1f} times the sd of a "
                            f"difference: {_reading(h.p_value, s_star, s)}"),
            }
        devices[f"device {device}"] = {"axes": axes, "checks": record["checks"],
                                       "trustworthy": record["trustworthy"]}
    return {
        "assumed_within_test_sd": s,
        "assumption": (f"each printed K is the paper's estimator on 180 s means of a FOG with "
                       f"ARW {ASSUMED_ARW_DEG_RT_H} deg/sqrt(h) (gyroid's simulated FOG; the "
                       "paper gives no noise figure): sd = sqrt(2) ARW 60 / sqrt(180) / 6"),
        "priors": "population mean Normal(0, 1), between-test sd HalfNormal(0.5), deg/h per "
                  "100 uT",
        "devices": devices,
    }


def _reading(p_value: float, s_star: float, s: float) -> str:
    ratio = f"{s_star:.3g}, {s_star / s:.1f} times the assumed {s:.3g}"
    if p_value < 0.05:
        return f"real test-to-test variation, unless each test's sd exceeds {ratio}"
    return f"within the noise, unless each test's sd is below {ratio}"
