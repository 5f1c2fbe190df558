"""A native log's IMU streams as a log table in the contract's columns: every reader of a
flight-controller or robot log (:mod:`gyroid.io._native`) ends here. The gyro's three axes
become ``drift_x_deg_h``, ``drift_y_deg_h``, ``drift_z_deg_h`` (deg/h; a static log's
rate is its drift: Earth's rate stays in the bias), the temperature is put on the gyro's
clock, the accelerometer (when the log has it) becomes ``ax_g``, ``ay_g``, ``az_g`` (g) on
the gyro's clock, and what was picked is recorded for ``axes.json``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._log_table import LogTable

RAD_S_TO_DEG_H = 180.0 / np.pi * 3600.0
#: Standard gravity, m/s^2 per g.
STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True)
class ImuStreams:
    """One IMU's streams as read from a native log: sample times (s), the gyro's three axes
    (rad/s, or ``deg_s`` when the format logs deg/s), the temperature (degC) on its own clock,
    and what the reader picked (stream, instance, units) in words; the accelerometer's
    three axes in m/s^2 on ``accel_time_s`` (None: the gyro's clock), None when not logged."""

    time_s: np.ndarray
    gyro: np.ndarray  # (n, 3)
    temperature_time_s: np.ndarray | None
    temperature_C: np.ndarray | None
    picked: dict[str, object]
    gyro_unit: str = "rad/s"
    accel: np.ndarray | None = None  # (m, 3), m/s^2
    accel_time_s: np.ndarray | None = None


def imu_table(path: Path, streams: ImuStreams) -> LogTable:
    """The contract columns of one IMU's streams (see the module docstring). Rows outside
    the temperature stream's span are dropped (an interpolation never extrapolates), and
    repeated time stamps are refused by the table's checks as any log's would be."""
    time_s = np.asarray(streams.time_s, dtype=float)
    gyro = np.asarray(streams.gyro, dtype=float)
    if time_s.size == 0:
        raise GyroidInputError(f"{path.name}: the gyro stream {streams.picked.get('stream')!r} "
                               "has no samples")
    order = np.argsort(time_s, kind="stable")
    time_s, gyro = time_s[order], gyro[order]
    accel = _accel_on_gyro_clock(streams, order, time_s)
    scale = RAD_S_TO_DEG_H if streams.gyro_unit == "rad/s" else 3600.0
    picked = dict(streams.picked) | {"gyro_unit": streams.gyro_unit,
                                     "converted_to": "deg/h"}
    raw = {"time_s": time_s}
    if streams.temperature_C is not None:
        t_temp = np.asarray(streams.temperature_time_s, dtype=float)
        temperature = np.asarray(streams.temperature_C, dtype=float)
        keep_temp = np.isfinite(temperature)
        t_temp, temperature = t_temp[keep_temp], temperature[keep_temp]
        if t_temp.size:
            inside = (time_s >= t_temp.min()) & (time_s <= t_temp.max())
            if not np.any(inside):
                raise GyroidInputError(f"{path.name}: the temperature stream does not overlap "
                                       "the gyro's in time; check the log")
            if not np.all(inside):
                picked["rows_outside_temperature_dropped"] = int(np.sum(~inside))
                time_s, gyro = time_s[inside], gyro[inside]
                accel = None if accel is None else accel[inside]
                raw["time_s"] = time_s
            order_t = np.argsort(t_temp, kind="stable")
            raw["temperature_C"] = np.interp(time_s, t_temp[order_t], temperature[order_t])
        else:
            picked["temperature"] = "none logged (every value missing)"
    for k, axis in enumerate("xyz"):
        raw[f"drift_{axis}_deg_h"] = gyro[:, k] * scale
    if accel is not None:
        picked["accelerometer"] = "m/s^2 converted to g"
        for k, axis in enumerate("xyz"):
            raw[f"a{axis}_g"] = accel[:, k] / STANDARD_GRAVITY
    header = tuple(raw)
    return LogTable(path, header, raw, int(time_s.size), None, None,
                    comments=tuple(f"{key}: {value}" for key, value in picked.items()),
                    picked=picked)


def _accel_on_gyro_clock(streams: ImuStreams, order: np.ndarray, time_s: np.ndarray
                         ) -> np.ndarray | None:
    """The accelerometer (m/s^2) at the gyro's samples (sorted as ``order`` sorts them),
    interpolated from its own clock when it has one; None when not logged or never finite.
    Beyond its stream's span the nearest sample is held (the accelerometer only places the
    gravity vector, which changes slowly on a bench)."""
    if streams.accel is None:
        return None
    accel = np.asarray(streams.accel, dtype=float).reshape(-1, 3)
    if streams.accel_time_s is None:
        accel = accel[order]
        return accel if np.isfinite(accel).all() else None
    t_accel = np.asarray(streams.accel_time_s, dtype=float)
    keep = np.isfinite(accel).all(axis=1) & np.isfinite(t_accel)
    if not np.any(keep):
        return None
    t_accel, accel = t_accel[keep], accel[keep]
    sort = np.argsort(t_accel, kind="stable")
    return np.column_stack([np.interp(time_s, t_accel[sort], accel[sort, k]) for k in range(3)])
