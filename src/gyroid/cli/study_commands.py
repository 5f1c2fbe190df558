"""Commands that run the studies: reproduce, demo."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.cli.base import (
    SEED,
    cli,
)
from gyroid.errors import GyroidInputError


@cli.command()
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for reproduce.json, tables.md and the figures.")
def reproduce(out) -> None:
    """Recompute both papers' tables and audit them against their own formulas."""
    from gyroid.pipeline._study_files import reproduce_dir

    click.echo("recomputing paper A's and paper B's tables and their figures ...", err=True)
    result = reproduce_dir(out)
    click.echo(f"{len(result['audit'])} disagreements found; wrote {out / 'reproduce.json'}")


@cli.command()
@click.option(
    "--out",
    "out",
    default=Path("gyroid-demo"),
    show_default=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder for the study.",
)
@click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed.")
def demo(out, seed) -> None:
    """The whole study on built-in data, written as report.md with figures."""
    from gyroid.pipeline._demo import run_demo

    report = run_demo(out, seed=seed, echo=click.echo)
    click.echo(f"report: {report}")


@cli.command()
@click.argument("name", required=False)
@click.option("--out", "out", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Folder to write the dataset's logs into (NAME.csv each, gyroid's columns, "
                   "with their provenance as comment lines).")
def datasets(name, out) -> None:
    """Public real gyro logs gyroid knows: list them, or with NAME and --out fetch one
    (into GYROID_DATA or the user's cache, checked by its SHA-256) and write its logs in
    gyroid's columns (one drift_AXIS_deg_h column per gyro axis)."""
    from gyroid.io._datasets import DATASETS, data_home
    from gyroid.pipeline._study_files import dataset_to_dir

    if name is None:
        for dataset in DATASETS.values():
            click.echo(f"{dataset.name}: {dataset.description} [{dataset.licence}]")
        click.echo(f"(kept in {data_home()}; set GYROID_DATA to move it)")
        return
    if out is None:
        raise GyroidInputError("give --out DIR to write the dataset's logs into")
    written = dataset_to_dir(name, out)
    click.echo(f"wrote {len(written)} log(s) of {name} to {out}: " + ", ".join(written))
