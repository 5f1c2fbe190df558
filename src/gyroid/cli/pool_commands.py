"""Commands on lots of runs or units of one gyro type: pool."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.cli.base import (
    SEED,
    TEMPERATURE,
    cli,
    map_option,
    parse_maps,
    prior_options,
    terms_option,
)
from gyroid.cli.report import report_checks


@cli.command()
@click.argument("logs", nargs=-1, required=True, type=click.Path(path_type=Path))
@terms_option()
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for pool.json, posterior.nc and forest.png.")
@click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed of NUTS.")
@click.option("--t0", "t0_C", default=21.0, show_default=True, type=TEMPERATURE,
              help="Reference temperature t0, degC (t = T - t0).")
@prior_options
@click.option("--segment-means", is_flag=True,
              help="Burst-sampled logs: pool one row per contiguous segment (its mean), so "
                   "the bias's wander between bursts is each run's noise; the samples are "
                   "still checked for spikes. A noise model that carries the wander itself "
                   "(auto, white+flicker+rw) fits each run's samples.")
@click.option("--noise", default="auto", show_default=True,
              type=click.Choice(["auto", "white", "white+flicker+rw", "white+gm"]),
              help="Each run's noise model, each run fitted on its own under it and its "
                   "coefficients' posterior pooled: auto is IEEE 952's white + flicker + rate "
                   "random walk, as 'gyroid fit' by default; white is right only where the "
                   "runs' noise is white at hours, which no check can see.")
@map_option
@click.option("--axis", "axis", default=None,
              help="The gyro axis to pool, for logs of several (x, y or z).")
@click.option("--instances", default=None,
              help="Pool the IMUs of flight-controller, ROS or MATLAB logs as runs: 'all' "
                   "or instance numbers such as 0,1,2 (runs named STEM#N).")
def pool(logs, terms, out, seed, t0_C, prior_choice, prior_items, segment_means, noise,
         mappings, axis, instances) -> None:
    """Pool repeated runs (or units) LOGS of one gyro type: the type's coefficients, the
    run-to-run spread (repeatability), each run's shrunk coefficients and the predictive
    for a new run, which 'gyroid compensate --fit OUT' uses. Each log is a bench log of one
    run (docs/formats.md section 1); runs are named by file stem, or by folder when stems repeat.
    Exit code 3 when a self-check says the result must not be used."""
    from gyroid.bench._options import BenchOptions
    from gyroid.models._prior_scales import resolve_prior_option
    from gyroid.pipeline._pool_runs import pool_to_dir

    prior_set, overrides = resolve_prior_option(prior_choice, prior_items)
    runs = BenchOptions(noise=noise, prior_set=prior_set, t0_C=t0_C,
                        segment_means=segment_means)
    result = pool_to_dir(logs, terms, out, runs, seed=seed, priors=overrides,
                         maps=parse_maps(mappings), axis=axis, instances=instances,
                         say=lambda m: click.echo(m, err=True))
    click.echo(result.summary())
    click.echo(f"wrote {out / 'pool.json'}, {out / 'posterior.nc'} and {out / 'forest.png'}")
    report_checks(result.checks)
