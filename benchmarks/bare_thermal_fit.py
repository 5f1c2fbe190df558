"""The baseline a competent researcher writes in an hour for a thermal drift fit: read the
log with pyarrow, estimate dT/dt by a Savitzky-Golay derivative of 1 s temperature means,
solve the normal equations, and sample w0, w1, w2, wD and the noise sd with emcee
(vectorised log-probability on sufficient statistics, DE moves, fixed 3000 steps).

    python benchmarks/bare_thermal_fit.py LOG.parquet

It prints one JSON line: the posterior means and the seconds each stage took. No checks, no
figures, no netCDF: that is the point of the comparison (benchmarks/scaling.py).
"""

from __future__ import annotations

import itertools
import json
import sys
import time

import emcee
import numpy as np
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
from scipy.signal import savgol_filter

T0_C = 21.0
WINDOW_S = 1200.0


def read(path: str) -> dict[str, np.ndarray]:
    if path.endswith(".parquet"):
        table = pq.read_table(path, columns=["time_s", "drift_deg_h", "temperature_C"])
    else:  # gyroid's CSV: comment lines start with '#'
        with open(path, "rb") as handle:
            skip = sum(1 for _ in itertools.takewhile(lambda line: line.startswith(b"#"),
                                                      handle))
        table = pacsv.read_csv(path, read_options=pacsv.ReadOptions(skip_rows=skip))
    return {name: table[name].to_numpy() for name in ("time_s", "drift_deg_h", "temperature_C")}


def rate_c_per_h(time_s: np.ndarray, temperature: np.ndarray) -> np.ndarray:
    """dT/dt from temperature means over bins of 1 s (or the sample interval, if longer):
    Savitzky-Golay, degree 5, over 1200 s."""
    width = max(1.0, float(np.median(np.diff(time_s))))
    index = np.floor((time_s - time_s[0]) / width).astype(int)
    counts = np.bincount(index)
    keep = counts > 0
    means = np.bincount(index, weights=temperature)[keep] / counts[keep]
    centres = np.bincount(index, weights=time_s)[keep] / counts[keep]
    window = int(WINDOW_S / width)
    window += 1 - window % 2
    slope = savgol_filter(means, window, 5, deriv=1, delta=width, mode="interp")  # degC/s
    return np.interp(time_s, centres, slope) * 3600.0


def thermal_design(data: dict[str, np.ndarray]) -> np.ndarray:
    """Paper A's thermal regressors: 1, t, t^2 (t = T - 21 degC) and dT/dt (degC/h)."""
    t = data["temperature_C"] - T0_C
    return np.column_stack([np.ones_like(t), t, t**2,
                            rate_c_per_h(data["time_s"], data["temperature_C"])])


def fit(path: str) -> dict:
    """The posterior means of one log and the seconds each stage took."""
    timings = {}
    start = time.perf_counter()
    data = read(path)
    timings["read_s"] = time.perf_counter() - start

    start = time.perf_counter()
    design = thermal_design(data)
    y = data["drift_deg_h"]
    gram, xy, yy, n = design.T @ design, design.T @ y, float(y @ y), y.size
    solution = np.linalg.solve(gram, xy)
    sd0 = float(np.sqrt((yy - xy @ solution) / (n - 4)))
    timings["design_s"] = time.perf_counter() - start

    def log_prob(theta):  # theta: (walkers, 5) = w0, w1, w2, wD, log sd
        w, log_sd = theta[:, :4], theta[:, 4]
        rss = yy - 2.0 * w @ xy + np.einsum("ki,ij,kj->k", w, gram, w)
        return -0.5 * rss / np.exp(2 * log_sd) - n * log_sd - 0.5 * np.sum((w / 100.0) ** 2, 1)

    start = time.perf_counter()
    walkers = 32
    rng = np.random.default_rng(0)
    p0 = np.concatenate([solution, [np.log(sd0)]]) + 1e-4 * rng.standard_normal((walkers, 5))
    sampler = emcee.EnsembleSampler(walkers, 5, log_prob, vectorize=True,
                                    moves=emcee.moves.DEMove())
    sampler.run_mcmc(p0, 3000, progress=False)
    chain = sampler.get_chain(discard=1000, flat=True)
    timings["sample_s"] = time.perf_counter() - start
    names = ("w0", "w1", "w2", "wD")
    return {"mean": dict(zip(names, chain[:, :4].mean(0).tolist(), strict=True)),
            "sigma_deg_h": float(np.exp(chain[:, 4]).mean()), **timings}


def main() -> None:
    print(json.dumps(fit(sys.argv[1])))


if __name__ == "__main__":
    main()
