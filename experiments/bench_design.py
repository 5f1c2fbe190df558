"""Experiment (b): which thermal bench design shrinks dK's uncertainty most.

For each design (setpoints, soak, transition, a return to the lab temperature) a bench is
simulated with paper A's truth and fitted (the linear-Gaussian posterior, exact, so no
sampler is needed); its posterior is propagated through paper B's worked example with the
fitted FOG as the stabiliser's reference gyro (the role in which the drift matters) and the
other inputs held at their nominal values and the period fixed at mid-flight (peak heating),
so the spread of dK is the bench's alone.

    python experiments/bench_design.py --seed 0
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _common import results_dir, save_run  # noqa: E402

from gyroid.bench import BenchOptions, BenchProblem
from gyroid.io import FittedDrift  # noqa: E402
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.simulation import ThermalProtocol, simulate_thermal_bench  # noqa: E402
from gyroid.workflows import SCENARIOS as PRESETS  # noqa: E402
from gyroid.workflows import propagate  # noqa: E402

DESIGNS = {
    "paper A (31...55, 40 min soaks)": ThermalProtocol(),
    "narrow (31, 35, 40)": ThermalProtocol(setpoints_C=(31.0, 35.0, 40.0)),
    "two setpoints (31, 55)": ThermalProtocol(setpoints_C=(31.0, 55.0)),
    "paper A + return to lab": ThermalProtocol(return_to_lab=True),
    "paper A, 80 min soaks": ThermalProtocol(soak_min=80.0),
    "paper A, 30 min transitions": ThermalProtocol(transition_min=30.0),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--draws", type=int, default=2000)
    args = parser.parse_args()
    started = time.time()
    rng = np.random.default_rng(args.seed)
    scenario = replace(PRESETS["paper_b_worked_stabiliser"], uncompensated_sd_deg_s=0.0,
                       mems_sf_error_sd=0.0, mems_bias_sd_deg_h=0.0, encoder_deg=0.0,
                       encoder_phase="0.0", temperature_rise_C=20.0, period_index=12)
    results = {}
    for name, protocol in DESIGNS.items():
        sim = simulate_thermal_bench(protocol=protocol, seed=int(rng.integers(2**31)))
        problem = BenchProblem.from_log(sim.log, "thermal",
                                        BenchOptions(noise="white", rate_window_s=RATE_WINDOW_S))
        point = problem.mode()
        p = problem.n_model
        draws = rng.multivariate_normal(point.u[:p], point.covariance_u[:p, :p], args.draws)
        fitted = FittedDrift(model=problem.model, draws=draws, t0_C=21.0)
        result = propagate(fitted, scenario, draws=args.draws, seed=args.seed, sobol_n=50)
        results[name] = {
            "hours": float(protocol.duration_s / 3600.0),
            "posterior_sd": {k: point.sd[k] for k in problem.model.parameter_names},
            "dK_mean": result.dk["mean"],
            "dK_sd_from_bench": result.dk["sd"],
        }
    order = sorted(results, key=lambda k: results[k]["dK_sd_from_bench"])
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    y = np.arange(len(order))
    ax.barh(y, [1e6 * results[k]["dK_sd_from_bench"] for k in order], color="0.4")
    ax.set_yticks(y, [f"{k} ({results[k]['hours']:.1f} h)" for k in order], fontsize=7)
    ax.set_xlabel("sd of dK due to the bench's coefficient uncertainty, ppm")
    fig.tight_layout()
    out = results_dir("bench_design")
    fig.savefig(out / "bench_design.png", dpi=150)
    save_run(out, seed=args.seed, config={"designs": list(DESIGNS), "draws": args.draws,
                                          "scenario": scenario.as_dict()},
             results={"by_design": results, "best": order[0]}, started=started)


if __name__ == "__main__":
    main()
