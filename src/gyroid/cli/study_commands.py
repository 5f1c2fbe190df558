"""Commands that run the studies: reproduce, demo."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.cli.base import (
    cli,
)
from gyroid.io._outputs import output_dir


@cli.command()
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for reproduce.json, tables.md and the figures.")
def reproduce(out) -> None:
    """Recompute both papers' tables and audit them against their own formulas."""
    from gyroid.reports._reproduction import write_reproduction

    with output_dir(out) as stage:
        result = write_reproduction(stage)
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
@click.option("--seed", default=0, show_default=True, type=int, help="Random seed.")
def demo(out, seed) -> None:
    """The whole study on built-in data, written as report.md with figures."""
    from gyroid.pipeline._demo import run_demo

    report = run_demo(out, seed=seed, echo=click.echo)
    click.echo(f"report: {report}")
