"""``gyroid export``: a fit's temperature model as a flight controller's parameters, or a
noise fit as an estimator's IMU noise file."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.cli.base import cli
from gyroid.cli.report import report_line
from gyroid.errors import UntrustworthyResult


@cli.command()
@click.argument("fit_dir", type=click.Path(path_type=Path))
@click.option("--to", "target", required=True,
              type=click.Choice(["px4", "ardupilot", "json", "kalibr", "openvins"]),
              help="From a 'gyroid fit' folder: px4 (a QGroundControl parameter file of "
                   "TC_G{i}_*), ardupilot (INS_TCAL{n}_* as NAME,VALUE lines), json (the "
                   "coefficients about t0 with their posterior). From a 'gyroid noise' "
                   "folder: kalibr (imu.yaml), openvins (kalibr_imu_chain.yaml). See "
                   "docs/formats.md section 5.")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the parameter or noise file and export.json.")
@click.option("--instance", default=0, show_default=True, type=click.IntRange(0, 3),
              help="The firmware's gyro: PX4's TC_G{N}, ArduPilot's INS_TCAL{N+1}.")
@click.option("--device-id", "device_id", default=None, type=click.IntRange(0),
              help="PX4's TC_G{i}_ID, the gyro's device_id (default: the one a ULog fit "
                   "records; PX4 applies the parameters only to the gyro with this id).")
@click.option("--topic", default=None,
              help="kalibr/openvins: the IMU's ROS topic (default: the bag's, else /imu0).")
def export(fit_dir, target, out, instance, device_id, topic) -> None:
    """Export every axis of FIT_DIR: a thermal fit's temperature polynomial re-centred
    exactly on the firmware's reference temperature, with the drift the terms it cannot
    represent leave (dT/dt, lag, magnetic...); or a noise fit's white noise and bias random
    walk, with how much the terms the estimator cannot represent (bias instability...)
    under-state the Allan deviation. Exit 3 when a fit exported is not trustworthy."""
    from gyroid.pipeline._export_file import export_dir

    result = export_dir(fit_dir, target, out, instance=instance, device_id=device_id,
                        topic=topic)
    for line in result.comments:
        click.echo(line)
    if target == "px4" and not result.record["device_id"]:
        report_line(f"TC_G{instance}_ID is 0: PX4 applies the parameters only to the gyro "
                    "whose device_id it names; give --device-id")
    names = [result.file_name] if result.file_name else []
    click.echo(f"wrote {', '.join(str(out / n) for n in [*names, 'export.json'])}")
    if not result.trustworthy:
        report_line("a fit exported is not trustworthy (exit 3): see the lines above")
        raise UntrustworthyResult()


@cli.command()
@click.argument("sheet", type=click.Path(path_type=Path))
@click.option("--to", "target", required=True,
              type=click.Choice(["kalibr", "openvins", "json"]),
              help="kalibr (imu.yaml), openvins (kalibr_imu_chain.yaml) or json (the "
                   "conversion alone); datasheet.json always.")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the estimator's file and datasheet.json.")
@click.option("--rate-hz", "rate_hz", default=None, type=click.FloatRange(min=0.0,
                                                                           min_open=True),
              help="The IMU's output rate, Hz (default: the datasheet's rate): the "
                   "file's update_rate and the discrete-time sds.")
@click.option("--horizon", "horizon_s", default=100.0, show_default=True,
              type=click.FloatRange(min=0.0, min_open=True),
              help="Without a rate_random_walk: the walk reaches B's flicker floor at this "
                   "averaging time, s.")
@click.option("--topic", default="/imu0", show_default=True, help="The IMU's ROS topic.")
def datasheet(sheet, target, out, rate_hz, horizon_s, topic) -> None:
    """Convert a gyro datasheet (SHEET: a TOML file with a [gyro] table of strings with
    units, docs/formats.md section 6) into an estimator's noise parameters, printing every
    step of the derivation."""
    from gyroid.pipeline._export_file import datasheet_file

    result = datasheet_file(sheet, target, out, rate_hz=rate_hz, horizon_s=horizon_s,
                            topic=topic)
    for line in result.derivation:
        click.echo(line)
    names = [result.file.file_name] if result.file is not None else []
    click.echo(f"wrote {', '.join(str(out / n) for n in [*names, 'datasheet.json'])}")
