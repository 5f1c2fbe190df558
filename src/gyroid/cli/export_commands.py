"""``gyroid export``: a fit's temperature model as a flight controller's parameters."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.cli.base import cli
from gyroid.io._outputs import output_dir


@cli.command()
@click.argument("fit_dir", type=click.Path(path_type=Path))
@click.option("--to", "target", required=True,
              type=click.Choice(["px4", "ardupilot", "json"]),
              help="px4: a QGroundControl parameter file of TC_G{i}_*; ardupilot: "
                   "INS_TCAL{n}_* as NAME,VALUE lines; json: the coefficients about t0 with "
                   "their posterior (docs/formats.md section 5).")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the parameter file and export.json.")
@click.option("--instance", default=0, show_default=True, type=click.IntRange(0, 3),
              help="The firmware's gyro: PX4's TC_G{N}, ArduPilot's INS_TCAL{N+1}.")
@click.option("--device-id", "device_id", default=None, type=click.IntRange(0),
              help="PX4's TC_G{i}_ID, the gyro's device_id (default: the one a ULog fit "
                   "records; PX4 applies the parameters only to the gyro with this id).")
def export(fit_dir, target, out, instance, device_id) -> None:
    """Export a fit's temperature polynomial (every axis of FIT_DIR) re-centred exactly on
    the firmware's reference temperature, with the drift the terms it cannot represent
    leave (dT/dt, lag, magnetic...) stated in the file and in export.json."""
    import json

    from gyroid.pipeline._compensate_file import fitted_axes
    from gyroid.reports._write import write
    from gyroid.workflows._export import axis_polynomial, export_fit

    fits = fitted_axes(fit_dir)
    if device_id is None and (Path(fit_dir) / "axes.json").exists():
        source = json.loads((Path(fit_dir) / "axes.json").read_text())["source"]
        device_id = source.get("device_id")
    result = export_fit({axis: axis_polynomial(axis, fitted) for axis, fitted in fits.items()},
                        target, instance=instance, device_id=device_id)
    with output_dir(out) as stage:
        write(stage, result)
    for line in result.comments:
        click.echo(line)
    if target == "px4" and not device_id:
        click.echo(f"TC_G{instance}_ID is 0: PX4 applies the parameters only to the gyro whose "
                   "device_id it names; give --device-id", err=True)
    names = [result.file_name] if result.file_name else []
    click.echo(f"wrote {', '.join(str(out / n) for n in [*names, 'export.json'])}")
