"""The baseline for ``gyroid compensate``: what a competent researcher writes in an hour to
compensate a thermal log with fitted coefficients. Read the log with pyarrow, estimate dT/dt
as the fit did (a Savitzky-Golay derivative of 1 s temperature means, as
``bare_thermal_fit.py``), evaluate w0 + w1 t + w2 t^2 + wD dT/dt with the posterior means
from gyroid's fit.json, write the compensated column as CSV, and compute the overlapping
Allan deviation before and after with allantools (octave-spaced tau, Greenhall's degrees of
freedom and confidence intervals, as gyroid's figure shows).

    python benchmarks/bare_compensate.py LOG.parquet FIT_DIR OUT.csv

It prints one JSON line: the compensated RMS and the seconds each stage took. No figures, no
posterior draws, no checks: that is the point of the comparison (benchmarks/scaling.py).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import allantools
import numpy as np
from bare_thermal_fit import T0_C, rate_c_per_h, read


def adev_with_bounds(rate: np.ndarray, sample_s: float) -> tuple[np.ndarray, ...]:
    """Overlapping Allan deviation at octave-spaced tau, with its 68 % bounds."""
    taus, adev, _, _ = allantools.oadev(rate, rate=1.0 / sample_s, data_type="freq",
                                        taus="octave")
    lower, upper = np.empty_like(adev), np.empty_like(adev)
    for i, (tau, dev) in enumerate(zip(taus, adev, strict=True)):
        edf = allantools.edf_greenhall(alpha=0, d=2, m=int(round(tau / sample_s)),
                                       N=rate.size, overlapping=True, modified=False)
        lower[i], upper[i] = allantools.confidence_interval(dev, edf)
    return taus, adev, lower, upper


def main() -> None:
    timings = {}
    start = time.perf_counter()
    data = read(sys.argv[1])
    posterior = json.loads((Path(sys.argv[2]) / "fit.json").read_text())["posterior"]
    timings["read_s"] = time.perf_counter() - start

    start = time.perf_counter()
    t = data["temperature_C"] - T0_C
    w = {k: posterior[k]["mean"] for k in ("w0", "w1", "w2", "wD")}
    model = (np.polyval([w["w2"], w["w1"], w["w0"]], t)
             + w["wD"] * rate_c_per_h(data["time_s"], data["temperature_C"]))
    after = data["drift_deg_h"] - model
    np.savetxt(sys.argv[3], np.column_stack([data["time_s"], after]), delimiter=",",
               header="time_s,drift_compensated_deg_h", comments="", fmt="%.10g")
    timings["compensate_s"] = time.perf_counter() - start

    start = time.perf_counter()
    sample_s = float(np.median(np.diff(data["time_s"])))
    for series in (data["drift_deg_h"], after):
        adev_with_bounds(series, sample_s)
    timings["allan_s"] = time.perf_counter() - start
    print(json.dumps({"rms_after_deg_h": float(np.sqrt(np.mean(after**2))), **timings}))


if __name__ == "__main__":
    main()
