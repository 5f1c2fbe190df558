"""The baseline a competent researcher writes in a day for a thermal drift fit whose noise is
correlated (what ``gyroid fit`` assumes by default): least squares first, the noise read off
the residual's Allan deviation by its slopes, then generalised least squares on block means
with the covariance those noise terms imply.

* read the log with pyarrow; dT/dt as ``bare_thermal_fit.py`` (Savitzky-Golay, 1200 s);
* ordinary least squares in 1, t, t^2, dT/dt; the residual's overlapping Allan deviation
  (allantools, octave-spaced tau);
* the angle random walk N from the shortest tau (slope -1/2), the rate random walk K from
  the longest when the curve rises there (slope +1/2; else none), the bias instability as a
  first-order Gauss-Markov process (sd the curve's minimum over 0.62, correlation time its
  tau over 1.89: the usual approximation);
* the rows averaged into at most 1000 blocks; their covariance: white N^2 / length, the
  walk K^2 min(t_i, t_j) at the block centres, the Gauss-Markov sd^2 exp(-|t_i - t_j| / Tc);
* generalised least squares by a Cholesky factor (scipy): the coefficients and their
  covariance.

    python benchmarks/bare_correlated_fit.py LOG.parquet

It prints one JSON line: the coefficients' means and sds, the noise terms and the seconds
each stage took. No priors, no posterior, no checks, no outputs written: that is the point
of the comparison (benchmarks/scaling.py).
"""

from __future__ import annotations

import json
import sys
import time

import allantools
import numpy as np
from bare_thermal_fit import read, thermal_design
from scipy.linalg import cho_factor, cho_solve

BLOCKS = 1000
NAMES = ("w0", "w1", "w2", "wD")


def allan_terms(residual: np.ndarray, sample_s: float) -> dict[str, float]:
    """N (deg/h sqrt(s)), K (deg/h/sqrt(s)) and the Gauss-Markov sd (deg/h) and correlation
    time (s) read off the residual's Allan deviation by its slopes."""
    taus, adev, _, _ = allantools.oadev(residual, rate=1.0 / sample_s, data_type="freq",
                                        taus="octave")
    n = float(adev[0] * np.sqrt(taus[0]))
    rising = adev.size >= 3 and np.all(np.diff(adev[-3:]) > 0)
    k = float(adev[-1] * np.sqrt(3.0 / taus[-1])) if rising else 0.0
    low = int(np.argmin(adev))
    return {"N": n, "K": k, "gm_sd": float(adev[low] / 0.62), "gm_tau_s": float(taus[low] / 1.89)}


def fit(path: str) -> dict:
    timings = {}
    start = time.perf_counter()
    data = read(path)
    timings["read_s"] = time.perf_counter() - start

    start = time.perf_counter()
    time_s = data["time_s"]
    design = thermal_design(data)
    y = data["drift_deg_h"]
    ols, *_ = np.linalg.lstsq(design, y, rcond=None)
    sample_s = float(np.median(np.diff(time_s)))
    terms = allan_terms(y - design @ ols, sample_s)
    timings["noise_s"] = time.perf_counter() - start

    start = time.perf_counter()
    block = np.minimum((np.arange(y.size) * min(BLOCKS, y.size)) // y.size, BLOCKS - 1)
    count = np.bincount(block).astype(float)
    mean_of = lambda v: np.bincount(block, weights=v) / count  # noqa: E731
    centre = mean_of(time_s - time_s[0])
    length = count * sample_s
    x = np.column_stack([mean_of(design[:, j]) for j in range(design.shape[1])])
    ybar = mean_of(y)
    gap = np.abs(centre[:, None] - centre[None, :])
    covariance = (np.diag(terms["N"] ** 2 / length)
                  + terms["K"] ** 2 * np.minimum(centre[:, None], centre[None, :])
                  + terms["gm_sd"] ** 2 * np.exp(-gap / terms["gm_tau_s"]))
    factor = cho_factor(covariance)
    precision_x = cho_solve(factor, x)
    information = x.T @ precision_x
    beta = np.linalg.solve(information, precision_x.T @ ybar)
    sd = np.sqrt(np.diag(np.linalg.inv(information)))
    timings["gls_s"] = time.perf_counter() - start
    return {"mean": dict(zip(NAMES, beta.tolist(), strict=True)),
            "sd": dict(zip(NAMES, sd.tolist(), strict=True)), "noise": terms, **timings}


if __name__ == "__main__":
    print(json.dumps(fit(sys.argv[1])))
