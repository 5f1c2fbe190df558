"""What ``gyroid export`` does with a result folder: read every axis of a drift fit (for a
flight controller's thermal parameters) or of a noise fit (for an estimator's noise file),
export it and write the files atomically."""

from __future__ import annotations

from pathlib import Path

from gyroid.errors import GyroidInputError
from gyroid.io._datasheet import read_datasheet
from gyroid.io._fitted import FittedDrift, FittedNoise, axes_of, axes_source
from gyroid.io._outputs import output_dir
from gyroid.reports._write import write
from gyroid.workflows._datasheet import HORIZON_S, DatasheetExport, convert_datasheet
from gyroid.workflows._export import TARGETS, FirmwareExport, axis_polynomial, export_fit
from gyroid.workflows._noise_export import NOISE_TARGETS, NoiseExport, axis_noise, export_noise


def export_dir(fit_dir: str | Path, target: str, out: str | Path, *, instance: int = 0,
               device_id: int | None = None, topic: str | None = None
               ) -> FirmwareExport | NoiseExport:
    """Export ``fit_dir`` (the ``--out`` folder of ``gyroid fit`` for px4, ardupilot and
    json; of ``gyroid noise`` for kalibr and openvins) to ``target`` and write it into
    ``out``. ``device_id`` and ``topic`` default to what the log's reader recorded."""
    source = axes_source(fit_dir)
    if target in NOISE_TARGETS:
        if not _has(fit_dir, "noise.json"):
            raise GyroidInputError(f"{fit_dir} is not a noise fit: --to {target} takes the "
                                   "--out folder of 'gyroid noise' (a static log)")
        fits = axes_of(fit_dir, FittedNoise.from_dir)
        sample_s = max(f.sample_s for f in fits.values())
        stream = str(source.get("stream") or "")
        result = export_noise({a: axis_noise(a, f) for a, f in fits.items()}, target,
                              sample_s=sample_s,
                              topic=topic or (stream if stream.startswith("/") else "/imu0"))
    elif target in TARGETS:
        if _has(fit_dir, "noise.json"):
            raise GyroidInputError(f"{fit_dir} is a noise fit: --to {target} takes the --out "
                                   "folder of 'gyroid fit' (a thermal model); a noise fit "
                                   f"exports to {' or '.join(NOISE_TARGETS)}")
        fits = axes_of(fit_dir, FittedDrift.from_dir)
        result = export_fit({a: axis_polynomial(a, f) for a, f in fits.items()}, target,
                            instance=instance, device_id=device_id or source.get("device_id"))
    else:
        raise GyroidInputError(f"--to {target!r}: use one of "
                               f"{', '.join((*TARGETS, *NOISE_TARGETS))}")
    with output_dir(out) as stage:
        write(stage, result)
    return result


def _has(folder: str | Path, name: str) -> bool:
    """Whether ``folder`` (or one of its axis folders) holds ``name``."""
    folder = Path(folder)
    if not folder.is_dir():
        raise GyroidInputError(f"{folder} is not a folder: give the --out folder of "
                               "'gyroid fit' or 'gyroid noise'")
    return (folder / name).exists() or any((d / name).exists() for d in folder.iterdir()
                                           if d.is_dir())


def datasheet_file(path: str | Path, target: str, out: str | Path, *,
                   rate_hz: float | None = None, horizon_s: float = HORIZON_S,
                   topic: str = "/imu0") -> DatasheetExport:
    """Convert the datasheet at ``path`` for ``target`` (kalibr, openvins or json) and write
    the estimator's file and ``datasheet.json`` into ``out``."""
    result = convert_datasheet(read_datasheet(path), target, rate_hz=rate_hz,
                               horizon_s=horizon_s, topic=topic)
    with output_dir(out) as stage:
        write(stage, result)
    return result
