"""Commands on paper B's loop: gyroid roll simulate, gyroid roll fit."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.cli.base import SEED, cli, map_option, parse_assignments, parse_maps
from gyroid.cli.report import report_checks, report_line
from gyroid.errors import GyroidInputError


@cli.group()
def roll() -> None:
    """Paper B's roll-gyro scale-factor correction: simulate and fit flights."""


@roll.command("simulate")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder to write roll.csv and truth.json into.")
@click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed.")
@click.option("--set", "overrides", default="", metavar="NAME=VALUE,...",
              help="Override roll-loop parameters (D0 deg/s, D1, D0gs deg/s, D1gs, Denc deg, "
                   "D2), e.g. 'D1=8e-4'.")
@click.option("--roll", "roll_profile", type=click.Choice(["constant", "ramp", "oscillating"]),
              default="oscillating", show_default=True, help="Roll-rate profile.")
@click.option("--rate", "rate", default=1800.0, show_default=True, type=float,
              help="Roll rate (constant), start (ramp) or mean (oscillating), deg/s.")
@click.option("--duration", default=120.0, show_default=True, type=float, help="Flight, s.")
@click.option("--period", default=5.0, show_default=True, type=float,
              help="Correction period dt, s.")
@click.option("--overload", default=0.0, show_default=True, type=float,
              help="Uncompensated fraction of the roll rate the stabiliser sees (0: ideal).")
@click.option("--gs-capacity", default=None, type=float,
              help="The stabiliser cancels roll rates up to this, deg/s; the excess is "
                   "uncompensated (an overloaded stabiliser).")
def roll_simulate(out, seed, overrides, roll_profile, rate, duration, period, overload,
                  gs_capacity) -> None:
    """Simulate a flight with known truth: roll.csv (docs/formats.md section 4) and truth.json."""
    from gyroid.pipeline._roll_files import simulate_roll_dir
    from gyroid.simulation._flight import FlightProfile

    if duration <= 0 or period <= 0 or period > duration:
        raise GyroidInputError("--duration and --period must be positive, period <= duration")
    profile = FlightProfile(duration_s=duration, period_s=period, roll=roll_profile,
                            roll_rate_deg_s=rate, overload_fraction=overload,
                            gs_capacity_deg_s=gs_capacity)
    click.echo(simulate_roll_dir(out, profile, parse_assignments(overrides, "--set"),
                                 seed=seed))


@roll.command("fit")
@click.argument("data", type=click.Path(path_type=Path))
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for roll_fit.json, posterior.nc and figures.")
@click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed of the sampler.")
@map_option
@click.option("--progress/--no-progress", default=True, show_default=True,
              help="Show the sampler's progress bar.")
def roll_fit(data, out, seed, mappings, progress) -> None:
    """Fit the loop parameters (D0, D1, D0gs, D1gs, Denc) to a roll log ROLL (.csv, .csv.gz
    or .parquet; docs/formats.md section 4). Exit code 3 when a self-check fails."""
    from gyroid.pipeline._roll_files import roll_fit_file

    result = roll_fit_file(data, out, maps=parse_maps(mappings), seed=seed, progress=progress,
                           say=lambda m: click.echo(m, err=True))
    for name, s in result.parameter_summaries.items():
        click.echo(f"  {name:>5s} = {s['mean']:.6g} +/- {s['sd']:.2g}")
    derived = []
    for item in result.confounded:
        pair = " and ".join(item.parameters)
        if item.follows_from:
            derived.append(f"{pair} (r = {item.correlation:.3f})")
            continue
        report_line(f"warning: {pair} are confounded (r = {item.correlation:.3f}): "
                    f"{item.suggestion}")
    if derived:
        report_line(f"warning: as a consequence, also confounded: {', '.join(derived)}")
    click.echo(f"wrote {out / 'roll_fit.json'} and {out / 'posterior.nc'}")
    report_checks(result.checks)
