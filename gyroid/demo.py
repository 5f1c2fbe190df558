"""`gyroid demo`: the study on built-in data, written as a report a researcher reads.

Current scope: paper A's two benches simulated with known truth, paper A's classic
estimators applied to them and to the paper's own table, with figures.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from gyroid.bench import ThermalProtocol, simulate_magnetic_bench, simulate_thermal_bench
from gyroid.classic import (
    chi2_of,
    magnetic_k,
    setpoint_readings,
    setpoint_table_fit,
)
from gyroid.datasets import paper_a_thermal_coefficients, paper_a_thermal_table
from gyroid.inputs import T0_C
from gyroid.logs import bench_log_text
from gyroid.outputs import json_text, output_dir
from gyroid.plotting import magnetic_sweep, save, thermal_run


def run_demo(out: str | Path, *, seed: int = 0, echo: Callable[[str], None] = print) -> Path:
    """Run the demo study into ``out``; returns the path of ``report.md``."""
    out = Path(out)
    sections: list[str] = ["# gyroid demo report", ""]
    results: dict = {"seed": seed}
    with output_dir(out) as stage:
        echo("[1/3] simulating paper A's thermal bench ...")
        protocol = ThermalProtocol()
        thermal = simulate_thermal_bench(protocol=protocol, seed=seed)
        (stage / "thermal").mkdir()
        (stage / "thermal" / "bench.csv").write_text(
            bench_log_text(thermal.log.columns, thermal.log.comments)
        )
        (stage / "thermal" / "truth.json").write_text(json_text(thermal.truth))
        inputs = thermal.log.inputs()
        save(
            thermal_run(thermal.log, np.asarray(inputs.rate_C_h), thermal.true_drift_deg_h),
            stage / "fig_thermal_run",
        )
        levels, means, rms = setpoint_readings(thermal.log, protocol.reading_windows_s(60.0))
        # Paper A's table: deviation from the lab-temperature reading, sigma = RMS.
        sim_fit = setpoint_table_fit(levels[1:], means[1:] - means[0], rms[1:])
        results["thermal"] = {
            "truth": thermal.truth["parameters"],
            "setpoint_table_fit": sim_fit.coefficients,
        }

        echo("[2/3] simulating paper A's magnetic bench ...")
        magnetic = simulate_magnetic_bench(seed=seed + 1)
        (stage / "magnetic").mkdir()
        (stage / "magnetic" / "bench.csv").write_text(
            bench_log_text(magnetic.log.columns, magnetic.log.comments)
        )
        (stage / "magnetic" / "truth.json").write_text(json_text(magnetic.truth))
        save(magnetic_sweep(magnetic.log), stage / "fig_magnetic_sweep")
        ks = {axis: magnetic_k(magnetic.log, axis) for axis in "xyz"}
        results["magnetic"] = {
            "truth": magnetic.truth["parameters"],
            "K": {f"w{a}": {"K": k.K, "signed": k.signed, "sd": k.sd} for a, k in ks.items()},
        }

        echo("[3/3] paper A's setpoint table ...")
        table = paper_a_thermal_table()
        printed = paper_a_thermal_coefficients()
        refit = setpoint_table_fit(table.setpoint_C, table.dw_deg_h, table.sigma_deg_h)
        t_rel = table.setpoint_C - T0_C
        chi2_printed = chi2_of(printed, t_rel, table.dw_deg_h, table.sigma_deg_h)
        results["paper_a_table"] = {
            "printed": {k: printed[k] for k in ("w0", "w1", "w2")} | {"chi2": chi2_printed},
            "refit": refit.coefficients | {"chi2": refit.chi2},
        }
        (stage / "demo.json").write_text(json_text(results))

        sections += [
            "Paper A's two benches simulated with known truth (seed "
            f"{seed}), and paper A's classic estimators applied to them.",
            "",
            "## Thermal bench",
            "",
            f"Setpoints {', '.join(f'{s:g}' for s in protocol.setpoints_C)} degC, "
            f"{protocol.transition_min:g} min transitions, {protocol.soak_min:g} min soaks, "
            f"1 Hz, ARW {thermal.truth['noise']['arw_deg_rt_h']} deg/sqrt(h).",
            "",
            "![Simulated thermal run](fig_thermal_run.png)",
            "",
            "*Figure 1. Simulated thermal run (paper A Fig. 1): drift, temperature and its "
            "estimated rate (local cubic over 10 min) against time.*",
            "",
            "| parameter | truth | paper A's setpoint-table method |",
            "|---|---|---|",
            *(
                f"| {k} | {thermal.truth['parameters'][k]:.4g} | {sim_fit.coefficients[k]:.4g} |"
                for k in ("w1", "w2")
            ),
            "",
            "The setpoint-table method subtracts the lab reading, so it cannot see w0, and it "
            "ignores wD.",
            "",
            "## Magnetic bench",
            "",
            "![Simulated Helmholtz sweep](fig_magnetic_sweep.png)",
            "",
            "*Figure 2. Simulated Helmholtz sweeps, OX, OY, then OZ after the azimuth turn.*",
            "",
            "| axis | truth, deg/h per 100 uT | paper A's K (signed) |",
            "|---|---|---|",
            *(
                f"| w{a} | {magnetic.truth['parameters'][f'w{a}']:.4g} | "
                f"{k.signed:.4g} +/- {k.sd:.2g} |"
                for a, k in ks.items()
            ),
            "",
            "## Paper A's own table",
            "",
            "| | w0 | w1 | w2 | chi2 (6 points) |",
            "|---|---|---|---|---|",
            f"| printed | {printed['w0']:.4g} | {printed['w1']:.4g} | {printed['w2']:.4g} | "
            f"{chi2_printed:.4g} |",
            f"| weighted refit | {refit.coefficients['w0']:.4g} | {refit.coefficients['w1']:.4g}"
            f" | {refit.coefficients['w2']:.4g} | {refit.chi2:.4g} |",
            "",
            "The printed coefficients reproduce the printed table poorly; a weighted refit of "
            "the same model does far better (see `demo.json`).",
            "",
        ]
        (stage / "report.md").write_text("\n".join(sections))
    return out / "report.md"
