"""Paper A Fig. 1: a (simulated) thermal run: drift, temperature and its rate against time."""

import json

import paths

from gyroid.io import load_bench_log
from gyroid.models import RATE_WINDOW_S
from gyroid.plotting import save, thermal_run

log = load_bench_log(paths.data("thermal", "bench.csv"), "thermal")
truth = json.loads(paths.data("thermal", "truth.json").read_text())
save(thermal_run(log, log.inputs().rate_C_h, rate_window_s=RATE_WINDOW_S),
     paths.figure("paper_a_fig1_thermal_run"), pdf=True)
print("thermal run, truth:", truth["parameters"])
