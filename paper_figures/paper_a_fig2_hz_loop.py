"""Paper A Fig. 2: drift against Hz while Hz rises and falls (the demo's log with a hidden
hysteresis shows the loop the paper saw)."""

import matplotlib.pyplot as plt
import numpy as np
import paths

from gyroid.io import load_bench_log
from gyroid.plotting import STYLE, save

DWELL_S = 180.0

log = load_bench_log(paths.data("discrepancy", "bench.csv"), "magnetic")
hz = log.columns["Hz_uT"]
on_z = np.abs(hz) > 1.0
start = np.flatnonzero(on_z)[0] - int(DWELL_S)  # the OZ sweep begins with a 0 uT dwell
t = log.time_s[start:]
drift, field = log.drift_deg_h[start:], hz[start:]
dwell = np.floor((t - t[0]) / DWELL_S).astype(int)
levels = np.array([field[dwell == k].mean() for k in np.unique(dwell)])
means = np.array([drift[dwell == k].mean() for k in np.unique(dwell)])
sem = np.array([drift[dwell == k].std(ddof=1) / np.sqrt((dwell == k).sum())
                for k in np.unique(dwell)])
rising = np.concatenate([[True], np.diff(levels) > 0])
with plt.rc_context(STYLE):
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    ax.errorbar(levels[rising], means[rising], yerr=sem[rising], fmt="o-", color="0.0",
                ms=4, capsize=2, label="Hz rising")
    ax.errorbar(levels[~rising], means[~rising], yerr=sem[~rising], fmt="s--", color="0.4",
                mfc="white", ms=4, capsize=2, label="Hz falling")
    ax.set_xlabel("Hz, uT")
    ax.set_ylabel("mean drift over each 180 s dwell, deg/h")
    ax.legend(frameon=False)
save(fig, paths.figure("paper_a_fig2_hz_loop"), pdf=True)
