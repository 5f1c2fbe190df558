"""Commands on bench logs: simulate, fit, compensate, propagate, discrepancy (both log kinds),
batch."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.cli.base import (
    POSITIVE,
    SEED,
    TEMPERATURE,
    FiniteFloat,
    axes_option,
    cli,
    fit_options,
    instance_option,
    map_option,
    parse_assignments,
    parse_axes,
    parse_effects,
    parse_maps,
    terms_help,
    terms_option,
)
from gyroid.cli.report import report_checks, report_line, report_written
from gyroid.errors import UntrustworthyResult


@cli.command()
@click.argument("bench", type=click.Choice(["thermal", "magnetic", "overload"]))
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder to write bench.csv, truth.json and bench.png into.",
)
@click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed.")
@click.option(
    "--set",
    "overrides",
    default="",
    metavar="NAME=VALUE,...",
    help="Override default coefficients, e.g. 'w1=-0.1,wD=2'.",
)
@click.option(
    "--effect",
    "effects",
    multiple=True,
    metavar="NAME:P=V,...",
    help="Switch on an effect with values, e.g. 'warmup:w_warmup=2,tau_warmup_min=15'. Repeatable.",
)
@click.option(
    "--arw", default=0.005, show_default=True, type=float, help="Angle random walk, deg/sqrt(h)."
)
@click.option(
    "--bias-instability",
    default=0.0,
    show_default=True,
    type=float,
    help="Bias instability (Gauss-Markov part), deg/h; 0 = white noise only.",
)
@click.option(
    "--correlation-time",
    default=300.0,
    show_default=True,
    type=float,
    help="Correlation time of the Gauss-Markov part, s.",
)
@click.option(
    "--average",
    "average_s",
    default=None,
    type=float,
    help="Write window averages over this many seconds (paper A: 60), with sigma_deg_h.",
)
@click.option("--hours", default=None, type=POSITIVE,
              help="Stretch the bench's schedule to last this long, h (every phase alike).")
@click.option("--rate-hz", "rate_hz", default=None, type=POSITIVE,
              help="Sample rate, Hz (default: the paper's 1 Hz).")
@click.option("--format", "log_format", type=click.Choice(["csv", "parquet"]), default="csv",
              show_default=True,
              help="Write bench.csv (the contract's CSV) or bench.parquet (the same columns; "
                   "what a log too long for memory is fitted from as a stream).")
@click.option("--runs", default=1, show_default=True, type=click.IntRange(1),
              help="Simulate a lot of this many runs (or units) of one gyro type, each "
                   "with its own coefficients drawn from the population, into "
                   "OUT/run_NN/bench.csv, with the lot's truth in OUT/lot.json.")
@click.option("--spread", default=0.2, show_default=True, type=float,
              help="With --runs: each coefficient's between-run sd as a fraction of its "
                   "magnitude.")
@click.option("--orientations", default=None, metavar="+X,-X,...",
              help="Overload bench: the directions of the specific force the unit dwells "
                   "in, in order (default: the six-position tumble +X,-X,+Y,-Y,+Z,-Z).")
def simulate(
    bench, out, seed, overrides, effects, arw, bias_instability, correlation_time, average_s,
    hours, rate_hz, log_format, runs, spread, orientations,
) -> None:
    """Simulate paper A's thermal, magnetic or overload bench with known truth (of any
    length and sample rate with --hours and --rate-hz; a lot of runs with --runs). A thermal
    log of more than 2 x 10^7 rows is written chunk by chunk, never held whole."""
    from gyroid.pipeline._simulate_file import SimulateOptions, simulate_to_dir
    from gyroid.simulation._bench import preset_parameters
    from gyroid.simulation._noise import GyroNoise

    options = SimulateOptions(
        parameters=preset_parameters(bench) | parse_assignments(overrides, "--set"),
        effects=parse_effects(effects),
        noise=GyroNoise(arw_deg_rt_h=arw, bias_instability_deg_h=bias_instability,
                        correlation_time_s=correlation_time),
        seed=seed, hours=hours, rate_hz=rate_hz, average_s=average_s, log_format=log_format,
        runs=runs, spread=spread,
        orientations=None if orientations is None else tuple(
            item.strip().upper() for item in orientations.split(",") if item.strip()))
    click.echo(simulate_to_dir(bench, out, options, say=lambda m: click.echo(m, err=True)))


@cli.command()
@click.argument("data", type=click.Path(path_type=Path))
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder to write fit.json, posterior.nc and figures into.")
@fit_options
def fit(data, out, options) -> None:
    """Fit the drift model TERMS to a bench log DATA (point estimate, posterior, checks).

    DATA is a bench log (.csv, .csv.gz or .parquet; docs/formats.md). Exit code 3 when a
    self-check says the result must not be used."""
    from gyroid.pipeline._fit_file import fit_file

    result = fit_file(data, options, out, say=lambda m: click.echo(m, err=True))
    for axis, fit in result.results.items():
        click.echo(f"axis {axis}: " + fit.point_summary() if result.several else
                   fit.point_summary())
    report_written(result, out, ("fit.json", "posterior.nc", "fit.png", "pair.png"))


@cli.command()
@click.argument("data", type=click.Path(path_type=Path))
@click.option("--fit", "fit_dir", required=True, type=click.Path(path_type=Path),
              help="The --out folder of 'gyroid fit' (fit.json and posterior.nc).")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for compensated.csv, compensate.json and figures.")
@click.option("--seed", default=0, show_default=True, type=SEED,
              help="Seed for choosing posterior draws.")
@click.option("--window", "window_s", default=600.0, show_default=True,
              type=click.FloatRange(min=0.0, min_open=True),
              help="compensated_means.csv: the means over consecutive windows of this many "
                   "seconds, with the 95 % band for each (model and noise).")
@click.option("--another-run", is_flag=True,
              help="DATA is another power-on than the fitted run's (another day, a restart): "
                   "its bias differs by the turn-on repeatability, which a fit of one run "
                   "cannot know; give --turn-on-sd or --rezero, or compensate with a "
                   "'gyroid pool' folder.")
@click.option("--turn-on-sd", "turn_on_sd", default=None, type=FiniteFloat(0.0),
              metavar="DEG_H",
              help="The spread of the bias at each power-on about the unit's mean, deg/h (1 "
                   "sigma; a datasheet's initial bias error, or a pool's between-run sd): "
                   "another run differs from the fitted one by sqrt(2) times it. Implies "
                   "--another-run.")
@click.option("--rezero", "rezero_s", default=None, type=POSITIVE, metavar="SECONDS",
              help="DATA starts with SECONDS at rest whose mean sets its bias, as a "
                   "firmware's start-up calibration does: the model predicts the drift's "
                   "change from that mean (another power-on's turn-on bias does not enter).")
@map_option
@axes_option
@instance_option
def compensate(data, fit_dir, out, seed, window_s, another_run, turn_on_sd, rezero_s,
               mappings, axes, instance) -> None:
    """Compensate a new bench log DATA with a fitted drift model; Allan deviation before and
    after. Every axis a fit of several has (--axes to choose). Exit code 3 when a self-check
    (extrapolation, gain, the predictive check, another run's unknown turn-on bias) says not
    to use it."""
    from gyroid.pipeline._compensate_file import compensate_file
    from gyroid.workflows._turn_on import TurnOn

    click.echo(f"compensating {data} with {fit_dir} ...", err=True)
    result = compensate_file(data, fit_dir, out, seed=seed, maps=parse_maps(mappings),
                             axes=parse_axes(axes), instance=instance, window_s=window_s,
                             turn_on=TurnOn(another_run or turn_on_sd is not None, turn_on_sd,
                                            rezero_s))
    for axis, item in result.results.items():
        s = item.summary
        which = f"axis {axis}: " if result.several else ""
        click.echo(f"{which}RMS {s['rms_before_deg_h']:.3g} -> {s['rms_after_deg_h']:.3g} "
                   f"deg/h ({100 * s['fraction_removed']:.0f} % removed)")
    if not (another_run or turn_on_sd is not None or rezero_s is not None) and any(
            item.summary["model_source"] == "fit posterior" for item in result.results.values()):
        click.echo(f"note: the bands take {data} to be the fitted run's own power-on; for "
                   "another run's, add --another-run with --rezero SECONDS, --turn-on-sd "
                   "DEG_H, or a 'gyroid pool' fit", err=True)
    report_written(result, out, ("compensated.csv", "compensated_means.csv", "compensate.json",
                                 "compensation.png", "allan.png"))


@cli.command()
@click.argument("fit_dir", type=click.Path(path_type=Path))
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for propagate.json and figures.")
@click.option("--scenario", default=None, metavar="NAME|FILE",
              help="A preset (paper_b_worked, paper_b_worked_stabiliser, ideal_stabiliser, "
                   "table2) or a JSON/TOML file of scenario fields. Default: paper_b_worked.")
@click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed.")
@click.option("--draws", default=2000, show_default=True, type=click.IntRange(10),
              help="Monte-Carlo draws for the distributions.")
def propagate(fit_dir, out, scenario, seed, draws) -> None:
    """Push a fit's posterior through paper B's correction loop: dK, roll and lateral error."""
    from gyroid.pipeline._propagate_file import propagate_dir
    from gyroid.workflows._propagate import driver_shares

    result = propagate_dir(fit_dir, out, scenario, draws=draws, seed=seed,
                           say=lambda m: click.echo(m, err=True))
    dk = result.dk
    click.echo(f"dK = {dk['mean']:.3g} +/- {dk['sd']:.2g} (95 % {dk['ci95'][0]:.3g} ... "
               f"{dk['ci95'][1]:.3g}); wrote {out / 'propagate.json'}")
    shares = sorted(driver_shares(result.sobol)["drivers"].items(), key=lambda kv: -kv[1])
    click.echo("its spread comes from (shares with interactions): " + ", ".join(
        f"{name} {share:.2f}" for name, share in shares if share >= 0.01))
    report_checks(result.checks)


@cli.command()
@click.argument("data", type=click.Path(path_type=Path))
@terms_option(lambda: "The model to start from. Bench log: " + terms_help() + " Roll log: "
                   "presets ideal, loop, or roll effects (sf_error, gs_bias, roll_bias, "
                   "gs_rate_leak, encoder_error, sf_nonlinearity).")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for discrepancy.json and discrepancy.png.")
@click.option("--t0", "t0_C", default=21.0, show_default=True, type=TEMPERATURE,
              help="Reference temperature t0, degC.")
@click.option("--max-added", default=3, show_default=True, type=click.IntRange(0),
              help="Stop after adding this many effects.")
@click.option("--extra-columns", is_flag=True,
              help="Offer every other numeric column of the log (pressure, supply voltage, "
                   "a second thermometer...) as a candidate cause extra:COLUMN, on the same "
                   "evidence scale as the catalogue.")
@map_option
@axes_option
@instance_option
def discrepancy(data, terms, out, t0_C, max_added, extra_columns, mappings, axes, instance
                ) -> None:
    """Find what the model TERMS misses in DATA, add it, refit, show the gap shrink.

    DATA is a bench log (docs/formats.md section 1; each gyro axis of a log of several, and
    what several show at once) or a roll log (section 4: roll_rate_deg_s, gs_angle_deg), as
    .csv, .csv.gz or .parquet. Exit code 3 when a self-check of the final model fails."""
    from gyroid.pipeline._discrepancy_file import discrepancy_file

    result = discrepancy_file(data, out, terms, t0_C=t0_C, max_added=max_added,
                              extra_columns=extra_columns, maps=parse_maps(mappings),
                              axes=parse_axes(axes), instance=instance,
                              say=lambda m: click.echo(m, err=True))
    for axis, report in result.results.items():
        for line in report.summary_lines():
            click.echo(f"axis {axis}: {line}" if result.several else line)
    for cause in result.shared:
        click.echo(f"shared: {cause['evidence']}")
    report_written(result, out, ("discrepancy.json", "discrepancy.png"))


@cli.command()
@click.argument("logs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for one sub-folder of fit files per log, batch.csv and batch.json.")
@click.option("--workers", default=2, show_default=True, type=click.IntRange(1),
              help="Worker processes of the local Dask cluster.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="An existing Dask scheduler (e.g. tcp://host:8786) instead of a local "
                   "cluster; its workers must see the same file system.")
@fit_options
def batch(logs, out, workers, scheduler, options) -> None:
    """Fit many bench logs LOGS of one gyro type (a production lot, repeated runs), one fit
    each, in parallel on Dask, every one as 'gyroid fit' would with the same options. A log
    that cannot be fitted fails alone (batch.json says why). Exit code 3 when a log failed
    or a fit is not trustworthy."""
    from gyroid.pipeline._batch import run_batch

    click.echo(f"fitting {len(logs)} logs with {workers} workers ...", err=True)
    result = run_batch(logs, options, out, workers=workers, scheduler=scheduler,
                       progress=lambda m: click.echo(m, err=True))
    failed = [o for o in result.outcomes if o.failed]
    doubtful = [o for o in result.outcomes if not o.failed and not o.trustworthy]
    click.echo(f"{len(logs) - len(failed)} fitted, {len(failed)} failed; wrote "
               f"{out / 'batch.csv'} and {out / 'batch.json'}")
    for outcome in failed:
        report_line(f"failed: {outcome.log}: {outcome.message}")
    for outcome in doubtful:
        report_line(f"not trustworthy: {outcome.log} (see its fit.json checks)")
    if failed or doubtful:
        raise UntrustworthyResult()


@cli.command()
@click.argument("data", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for noise.json and allan.png (a folder per axis for several); "
                   "for several runs, a folder per run and unit/ (unit.json, unit.png).")
@click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed.")
@map_option
@axes_option
@instance_option
@click.option("--static", "static_deg_s", default=None, type=click.FloatRange(min=0.0,
                                                                              min_open=True),
              help="Keep only still stretches (deg/s): rows whose rate, averaged over 1 s, "
                   "is within this of its median on every axis (a few times the 1 s "
                   "average's noise), less 1 s either side of motion, in stretches of 10 s "
                   "or more; what was kept is in axes.json's source.")
@click.option("--datasheet", "datasheet", default=None, type=click.Path(path_type=Path),
              help="A datasheet TOML file (docs/formats.md section 6): each term it gives "
                   "judged within, above or below the measured interval (noise.json's spec).")
def noise(data, out, seed, mappings, axes, instance, static_deg_s, datasheet) -> None:
    """Identify a static log's noise: angle random walk N, bias instability B, rate random
    walk K, quantisation Q and rate ramp R (IEEE Std 952) with 90 % intervals, averaged over
    the sets of terms the log supports, beside a Gauss-Markov bias G and a prefilter's
    deficit F; terms it cannot resolve get an upper bound. Several DATA logs are runs of one
    unit (or lot): each is fitted, then the unit's terms with the run-to-run spread and the
    interval a new run should land in. Exit code 3 when a self-check says not to use it."""
    from gyroid.pipeline._noise_file import NoiseOptions, noise_file, noise_unit_files

    options = NoiseOptions(seed=seed, maps=parse_maps(mappings), axes=parse_axes(axes),
                           instance=instance, static_deg_s=static_deg_s, datasheet=datasheet)
    if len(data) > 1:
        runs = noise_unit_files(data, out, options, say=lambda m: click.echo(m, err=True))
        for axis, unit in runs.unit.results.items():
            which = f"axis {axis}: " if runs.unit.several else ""
            click.echo(which + unit.summary().replace("\n", "\n" + which))
        report_written(runs.unit, out / "unit", ("unit.json", "unit.png"))
        return
    click.echo(f"fitting the noise of {data[0]} ...", err=True)
    result = noise_file(data[0], out, options)
    kept = result.source.get("static")
    if isinstance(kept, dict):
        click.echo(f"--static {kept['threshold_deg_s']:g}: kept {kept['rows_kept']} of "
                   f"{kept['rows']} rows in {kept['stretches']} still stretch(es)", err=True)
    for axis, item in result.results.items():
        which = f"axis {axis}: " if result.several else ""
        for line in (*item.term_lines(), *item.spec_lines()):
            click.echo(which + line)
    report_written(result, out, ("noise.json", "allan.png"))
