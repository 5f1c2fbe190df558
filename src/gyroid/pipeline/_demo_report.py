"""The demo's report.md: its sections, each written from what the study computed
(:mod:`gyroid.pipeline._demo`)."""

from __future__ import annotations

import numpy as np

from gyroid.models._effects import parameter
from gyroid.pipeline._demo_study import Study


def _fmt(mean: float, sd: float) -> str:
    digits = max(0, -int(np.floor(np.log10(abs(sd))))) + 1 if sd > 0 else 3
    return f"{mean:.{digits}f} +/- {sd:.{digits}f}"


def _fit_table(fit, truth: dict[str, float]) -> list[str]:
    rows = ["| parameter | unit | truth | posterior mean +/- sd | 95 % interval | r_hat | "
            "ess_bulk |", "|---|---|---|---|---|---|---|"]
    for name in fit.model_names:
        s = fit.posterior.summary[name]
        rows.append(f"| {name} | {parameter(name).unit} | {truth[name]:g} | "
                    f"{_fmt(s['mean'], s['sd'])} | "
                    f"[{s['ci95'][0]:.4g}, {s['ci95'][1]:.4g}] | {s['r_hat']:.3f} | "
                    f"{s['ess_bulk']:.0f} |")
    return rows


class Report:
    """report.md as it is written: text and numbered figures, in order."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.figures = 0

    def add(self, *lines: str) -> None:
        self.lines.extend(lines)

    def figure(self, name: str, caption: str) -> None:
        self.figures += 1
        self.lines.extend([f"![Figure {self.figures}]({name}.png)", "",
                           f"*Figure {self.figures}. {caption}*", ""])

    def text(self) -> str:
        return "\n".join(self.lines)


def _verdict(result) -> tuple[str, str]:
    """Whether to use a result, and what to do: its failed checks by name, errors first."""
    failed = result.checks.failed
    errors = [c.name for c in failed if c.severity == "error"]
    warnings = [c.name for c in failed if c.severity == "warning"]
    if errors:
        return "**no** (exit 3)", f"deal with {', '.join(errors)} (docs/checks.md)"
    if warnings:
        return "yes", f"read the warning(s) {', '.join(warnings)} below"
    return "yes", "nothing"


def _held(fit, truth: dict[str, float]) -> str:
    """How many of a fit's 95 % intervals hold their truths."""
    held = sum(fit.posterior.summary[k]["ci95"][0] <= truth[k] <= fit.posterior.summary[k][
        "ci95"][1] for k in fit.model_names)
    return f"{held} of {len(fit.model_names)} 95 % intervals hold the truth"


def _summary_section(report: Report, study: Study) -> None:
    """What was found, which answers to trust and what to do, before the details."""
    rows = ["| answer | found | use it? | what to do |", "|---|---|---|---|"]
    for name in ("thermal", "magnetic"):
        fit = study.fits[name]
        truth = study.benches[name].truth["parameters"]
        rows.append(f"| {name} fit (`{name}/fit/fit.json`) | {_held(fit, truth)} | "
                    + " | ".join(_verdict(fit)) + " |")
    dk = study.results["propagation"].to_json()["dK"]
    rows.append(f"| paper B's dK (`propagate/propagate.json`) | {dk['mean'] * 1e6:.0f} +/- "
                f"{dk['sd'] * 1e6:.0f} ppm | as the thermal fit | as the thermal fit |")
    found = study.results.get("discrepancy")
    if found is not None:
        rows.append(f"| a hidden effect (`discrepancy/discrepancy.json`) | added: "
                    f"{', '.join(found.added) or 'none'} | " + " | ".join(_verdict(found))
                    + " |")
    compensation = study.results["compensation"]
    cs = compensation.summary
    rows.append(f"| a second run compensated (`compensate/compensate.json`) | RMS drift "
                f"{cs['rms_before_deg_h']:.3g} -> {cs['rms_after_deg_h']:.3g} deg/h | "
                + " | ".join(_verdict(compensation)) + " |")
    pooled = study.results["pooled"]
    rows.append(f"| {len(study.results['lot'].runs)} runs pooled (`pool/pool.json`) | the "
                "type's coefficients and a new run's | " + " | ".join(_verdict(pooled))
                + " |")
    report.add(
        "# gyroid demo: Bayesian identification of a FOG's drift and its effect on paper "
        "B's roll correction", "",
        f"Seed {study.seed}. Everything below was computed by `gyroid demo` in this folder; "
        "each section names the files behind it.", "",
        "## Summary", "",
        "Each answer, whether its self-checks let you use it (as the command line's exit code "
        "says: 0 or 3) and what to do; the sections below give the details.", "",
        *rows, "")


def _benches_section(report: Report, study: Study) -> None:
    thermal = study.benches["thermal"]
    report.add(
        "## 1. Paper A's benches, simulated with known truth", "",
        "Thermal bench: the gyro's temperature driven from 21 degC through the setpoints "
        "31...55 degC (1 h smooth transitions, 40 min soaks), 1 Hz, angle random walk "
        f"{thermal.truth['noise']['arw_deg_rt_h']} deg/sqrt(h) "
        f"({thermal.truth['noise']['white_sd_deg_h']:.2f} deg/h per sample). Truth: "
        "paper A's coefficients. Magnetic bench: Helmholtz sweeps 0 -> +300 -> -300 -> 0 "
        "uT in 50 uT steps, 180 s dwells, OX, OY, then OZ; truth: paper A's device 2.", "")
    report.figure("fig_thermal_run", "Simulated thermal run (paper A Fig. 1): the logged 1 Hz "
                  "drift (grey) over the true drift (black), the logged minus the true drift "
                  "(the simulated noise, too thin to see at the top panel's scale), the "
                  "temperature, and dT/dt as gyroid estimates it from the logged temperature "
                  "(local degree-5 polynomial over 20 min; the simulation's drift follows the "
                  "true dT/dt).")
    report.figure("fig_magnetic_sweep", "Simulated Helmholtz sweeps: logged drift with the "
                  "fitted magnetic model at its point estimate, and the field projections "
                  "against time; the gap is the azimuth turn before OZ.")


def _carried(fit) -> str:
    """What the likelihood carries of the thermometer's noise, if anything."""
    carried = fit.errors_in_variables
    if carried is None:
        return ""
    if carried.get("process"):  # under correlated noise: a process of the filter
        return (f" The likelihood carries the thermometer's noise "
                f"({carried['thermometer_sd_C']:.3f} degC, measured on the log) through the "
                f"dT/dt estimator's {fit.problem.rate_window_s:.0f} s window, times wD's "
                f"least-squares value ({carried['wD_fixed']:.3g}), as two oscillators in the "
                "noise model's filter, the log's ends exact where they matter (errors in "
                "variables): left out, the flicker and the walk would take it in and widen "
                "every interval.")
    means = fit.block_means
    rows = (f" It is fitted on {means['means']} means of {means['rows_per_mean']} samples, "
            "over which that covariance is held." if means else "")
    return (f" The likelihood carries the thermometer's noise ({carried['thermometer_sd_C']:.3f}"
            " degC, measured on the log) through the dT/dt estimator as a covariance "
            f"wD^2 v L L', wD at its least-squares value ({carried['wD_fixed']:.3g}; errors "
            "in variables): without it the white residuals fail their "
            f"whiteness check, since wD times the rate's error is correlated over the "
            f"estimator's {fit.problem.rate_window_s:.0f} s window.{rows}")


def _fits_section(report: Report, study: Study) -> None:
    tf, mf = study.fits["thermal"], study.fits["magnetic"]
    magnetic = study.benches["magnetic"]
    report.add(
        "## 2. Posteriors (optimistix point estimate, importance sampling or emcee, ArviZ "
        "diagnostics)", "",
        f"Thermal model `{','.join(tf.problem.model.terms)}`; noise model "
        f"`{tf.problem.noise.name}` ({tf.noise_choice or 'asked for'}), its levels sampled "
        f"({_noise_levels(tf)}); sampled by {tf.posterior.method}; files "
        f"`thermal/fit/`.{_carried(tf)}", "",
        *_fit_table(tf, study.benches["thermal"].truth["parameters"]), "",
        *_check_lines("thermal", tf.checks))
    report.figure("thermal/fit/pair", "Posterior of the thermal coefficients (truth dashed). "
                  "w1 and w2 are strongly anti-correlated: the setpoints span only "
                  "31...55 degC.")
    summary = mf.posterior.summary
    report.add(
        f"Magnetic model `{','.join(mf.problem.model.terms)}`; files `magnetic/fit/`.", "",
        *_fit_table(mf, magnetic.truth["parameters"]), "",
        *_check_lines("magnetic", mf.checks),
        "Paper A's classic estimator `K = |dw(+300) - dw(-300)| / 6` on the same log "
        "(signed here) uses only the two extreme dwells:", "",
        "| axis | unit | truth | classic K | Bayesian (all dwells) |", "|---|---|---|---|---|",
        *(f"| w{a} | {parameter(f'w{a}').unit} | {magnetic.truth['parameters'][f'w{a}']:g} | "
          f"{_fmt(k.signed, k.sd)} | {_fmt(summary[f'w{a}']['mean'], summary[f'w{a}']['sd'])} |"
          for a, k in study.results["classic_k"].items()),
        "",
        "The Bayesian estimate is about twice as precise: it uses every dwell, not two.", "")


def _propagation_section(report: Report, study: Study) -> None:
    scenario = study.results["scenario"]
    prop = study.results["propagation"].to_json()
    dk = prop["dK"]
    drivers = ", ".join(f"{k} {v:.2f}" for k, v in sorted(prop["drivers"].items(),
                                                         key=lambda kv: -kv[1]) if v >= 0.01)
    report.add(
        "## 3. From the fitted gyro to paper B's correction coefficient", "",
        f"Scenario `{scenario.name}`: roll {scenario.roll_rate_deg_s:g} deg/s, correction "
        f"period {scenario.period_s:g} s, uncompensated rate "
        f"{scenario.uncompensated_deg_s:g} +/- {scenario.uncompensated_sd_deg_s:g} deg/s, "
        f"MEMS SF error {scenario.mems_sf_error * 1e6:g} ppm, encoder "
        f"{scenario.encoder_deg:g} deg (uniform phase); the fitted FOG is the SINS roll "
        f"gyro, its drift driven by a {scenario.temperature_rise_C:g} degC rise in "
        f"{scenario.duration_s:g} s. {prop['draws']} draws; files `propagate/`.", "",
        f"- dK (a fraction; ppm in the figure) = {dk['mean']:.3g} +/- {dk['sd']:.2g} "
        f"({dk['mean'] * 1e6:.0f} +/- {dk['sd'] * 1e6:.0f} ppm; 95 %: "
        f"{dk['ci95'][0] * 1e6:.0f} ... {dk['ci95'][1] * 1e6:.0f} ppm); paper B prints "
        f"0.093 (93 000 ppm), its own eq. 7 gives {prop['closed_form']['dK_eq7']:.3g} "
        f"({prop['closed_form']['dK_eq7'] * 1e6:.0f} ppm).",
        f"- residual SF error after correction: {prop['sf_residual_ppm']['mean']:.0f} ppm "
        f"mean (of D1 = {scenario.sins_sf_error * 1e6:g} ppm before).",
        f"- roll-angle error at 120 s: {prop['dpsi_deg']['120']['mean']:.2f} +/- "
        f"{prop['dpsi_deg']['120']['sd']:.2f} deg; lateral error "
        f"{prop['dr_z_m']['120']['mean'] / 1000:.2f} +/- "
        f"{prop['dr_z_m']['120']['sd'] / 1000:.2f} km.",
        "- what drives dK's spread (share of its variance, interactions included: "
        f"normalised total Sobol indices): {drivers}; {prop['interactions']['share']:.2f} of "
        "the variance comes from interactions ("
        + (", ".join(prop["interactions"]["involving"]) or "none") + ").", "")
    report.figure("propagate/dk_distribution", "Distribution of dK over posterior draws and "
                  "correction periods, with paper B's eq. 7 value; the printed 0.093 is 500 "
                  "times larger.")
    report.figure("propagate/drivers", "First-order and total Sobol indices of dK (the title "
                  "gives the share of the variance that is interactions): the encoder error "
                  "acts through its phase at each period's end, so it matters only jointly "
                  "with the period.")


def _discrepancy_section(report: Report, study: Study) -> None:
    found = study.results.get("discrepancy")
    if found is None:
        return
    before, after = distinct(found.rms_baseline, found.rms_final)
    report.add(
        "## 4. What the model misses: the discrepancy workflow", "",
        "A magnetic log with a hidden hysteresis (offset following the sign of the last "
        "field change, 0.04 deg/h on OY, 0.06 on OZ) analysed with paper A's magnetic "
        "model; files `discrepancy/`.", "",
        *(f"- added **{s.effect}**: {s.evidence}" for s in found.steps),
        *(["- nothing added"] if not found.steps else []),
        f"- RMS {before} -> {after} deg/h", "")
    report.figure("discrepancy/discrepancy", "Residuals before and after adding the named "
                  "effect (top), the baseline residual against what the added effect "
                  "explains (on all three axes; the dashed line is 1:1), and the RMS of the "
                  "60 s means before and after (per-sample RMS in the labels: there the "
                  "white noise dominates).")


def _compensation_section(report: Report, study: Study) -> None:
    cs = study.results["compensation"].summary
    before, after = cs["allan_before"], cs["allan_after"]
    inside = ("Every input stayed inside the fitted range." if cs["within_fitted_range"] else
              "Inputs outside the fitted range: "
              + ", ".join(i["input"] for i in cs["extrapolation"]) + ".")
    report.add(
        "## 5. Compensation in service", "",
        "The thermal fit applied to a second run (another seed, setpoints 28, 36, 44, "
        f"52 degC): RMS drift {cs['rms_before_deg_h']:.3g} -> {cs['rms_after_deg_h']:.3g} "
        f"deg/h ({100 * cs['fraction_removed']:.1f} % removed), peak "
        f"{cs['peak_before_deg_h']:.3g} -> {cs['peak_after_deg_h']:.3g} deg/h; angle random "
        f"walk {before['arw_deg_rt_h']:.4f} -> {after['arw_deg_rt_h']:.4f} deg/sqrt(h). "
        "Before compensation the Allan deviation is the thermal drift itself (it peaks at "
        f"{before['floor_deg_h']:.3g} deg/h near tau = {before['floor_tau_s']:.0f} s, the "
        "heating cycles, not a noise floor); after it, the compensated residual's "
        + (f"floor is {after['floor_deg_h']:.3g} deg/h at tau = "
           f"{after['floor_tau_s']:.0f} s: what the compensation leaves (the model's error "
           "beside the gyro's noise), not the gyro's bias instability, which this simulated "
           "gyro does not have" if after["floor_resolved"] else
           "curve stays on the white noise's line: no floor above it is resolved")
        + f". {inside} Files `compensate/`.", "")
    report.figure("compensate/allan", "Allan deviation of the drift before and after "
                  "compensation, with 68 % intervals and the standard slopes; what remains "
                  "after is the white noise and a small correlated part from the estimated "
                  "dT/dt.")


def _papers_section(report: Report, study: Study) -> None:
    repro = study.results["reproduction"]
    report.add("## 6. Both papers reproduced and audited", "",
               "Files `reproduce/` (`reproduce.json`, `tables.md`).", "")
    report.figure("reproduce/paper_a_setpoint_table", "Paper A's setpoint table with its "
                  "printed coefficients and a weighted refit of the same quadratic.")
    report.figure("reproduce/paper_b_table2", "Paper B Table 2: lateral error by eq. 8, "
                  "exactly, the g t^2/2 bound, and the printed values.")
    report.add("Disagreements found:", "",
               *(f"- Paper {i['paper']}, {i['item']} ({i['quantity']}): printed "
                 f"{i['printed']:.4g}, recomputed {i['recomputed']:.4g}. {i['note']}"
                 for i in repro["audit"]))


def distinct(a: float, b: float, digits: int = 3) -> tuple[str, str]:
    """Two numbers with as many significant digits (at least ``digits``) as it takes to
    tell them apart: 0.304 and 0.3002, not 0.304 and 0.3."""
    for k in range(digits, 10):
        first, second = f"{a:.{k}g}", f"{b:.{k}g}"
        if first != second or a == b:
            return first, second
    return f"{a:.10g}", f"{b:.10g}"


def _pool_section(report: Report, study: Study) -> None:
    """Section 7: a simulated lot pooled against its truth, and paper A's table."""
    pooled, lot = study.results["pooled"], study.results["lot"]
    record = pooled.to_json()
    report.add("", "## 7. Many runs of one gyro type: pooling", "",
               "`gyroid pool` fits runs (or units) of one gyro type together: the type's "
               "coefficients (population mean), the run-to-run spread a datasheet calls "
               "repeatability, each run's coefficients shrunk towards the population, and "
               "the predictive for a new run, which `gyroid compensate --fit POOL` uses for "
               f"a unit that was never tested. {len(lot.runs)} simulated magnetic runs "
               "(files `pool/`, "
               f"truth in `pool/lot.json`; the runs' noise {record['run_noise']}):", "",
               "| coefficient | unit | true mean | population mean +/- sd | true between-run sd "
               "| between-run sd (95 %) | new run +/- sd |", "|---|---|---|---|---|---|---|")
    for name in pooled.coefficient_names:
        m, t = record["population"][name], record["between_run_sd"][name]
        new = record["new_run_predictive"][name]
        report.add(f"| {name} | {parameter(name).unit} | {lot.population_mean[name]:.4g} | "
                   f"{_fmt(m['mean'], m['sd'])} | {lot.between_run_sd[name]:.3g} | "
                   f"{t['mean']:.3g} ({t['ci95'][0]:.2g} ... {t['ci95'][1]:.2g}) | "
                   f"{_fmt(new['mean'], new['sd'])} |")
    verdict = ("trustworthy" if pooled.trustworthy else "**not trustworthy**")
    report.add("", f"Self-checks of the pooled fit: {verdict}.", "",
               *(f"- {line}" for line in pooled.checks.lines()), "")
    report.figure("pool/forest", "Forest plot: each run's own estimate (open circle, 95 %) "
                  "and its pooled coefficient (filled square), the population mean and a new "
                  "run's predictive (dashed bar); the simulated truths as crosses (each run) "
                  "and a dashed line (the population mean).")
    rep = study.results["reproduction"]["paper_a"]["magnetic_repeatability"]
    report.add("Paper A's magnetic table has two tests per device and no uncertainties. "
               f"Assumed: {rep['assumption']} = {rep['assumed_within_test_sd']:.4f} deg/h per "
               "100 uT. Is the test-to-test spread real?", "")
    for device, entry in rep["devices"].items():
        for axis, row in entry["axes"].items():
            report.add(f"- {device}, {axis} ({row['tests'][0]:g} / {row['tests'][1]:g}): "
                       f"{row['verdict']}.")
    report.add("", "Two tests cannot pin down a between-test sd (its interval is mostly the "
               "prior's), but they do answer whether the tests differ: device 2's wy and wz "
               "moved between tests by far more than a test's noise.", "")
    report.figure("reproduce/paper_a_magnetic_device2_pooled", "Paper A, device 2: the two "
                  "tests and their pooled coefficients.")


def _noise_levels(fit) -> str:
    """The posterior means of a fit's noise levels, with units."""
    summary, units = fit.posterior.summary, fit.problem.noise.units
    return ", ".join(f"{name} {summary[name]['mean']:.3g} {units[name]}"
                     for name in fit.problem.noise_names)


def _check_lines(name: str, checks) -> list[str]:
    """The self-checks' verdict on a fit, with every failed check, for the report."""
    verdict = ("trustworthy: every error-level self-check passed" if checks.trustworthy else
               "**not trustworthy** (the CLI would exit with code 3)")
    lines = [f"Self-checks of the {name} fit: {verdict}."]
    lines += [f"- {line}" for line in checks.lines()]
    if name == "thermal" and not checks.trustworthy:
        lines.append("- Why: the drift is simulated with the true dT/dt, the fit sees the "
                     "estimated one; the estimator's smoothing at the setpoint transitions "
                     "leaves structure in the residuals (errors in variables) that the "
                     "fit's noise model does not describe.")
    return [*lines, ""]



#: The report's sections, in order.
SECTIONS = (_summary_section, _benches_section, _fits_section, _propagation_section,
            _discrepancy_section, _compensation_section, _papers_section, _pool_section)
