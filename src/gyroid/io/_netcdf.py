"""netCDF logs (``.nc``: netCDF-4/HDF5 through h5netcdf, classic through SciPy; read with
xarray, times decoded here so that no calendar library is needed): contract section 6.

A log is the variables along its time dimension. Each becomes a column, a variable with an
axis dimension one per axis (``gyro_x`` from labels x, y, z on that dimension, or x, y, z
for a dimension of three, else ``NAME_1``, ``NAME_2`` ...); ``--map`` names them so, or as
``NAME[x]``. The contract's columns are recognised by each variable's ``units`` attribute
(an angular rate is the gyro, an acceleration the accelerometer, a magnetic field the
magnetometer, a temperature the thermometer) and, for the axis, by the name's ending or the
axis label; where that is ambiguous (two gyros, two thermometers) the message lists the
candidates and ``--map`` chooses. A recognised variable is read under its contract name
only; one a map names is not recognised as anything else. A mapped variable's unit is its
``units`` attribute unless the map gives one.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._log_table import LogTable
from gyroid.io._unit_names import canonical_unit, quantity
from gyroid.io._units import ColumnMap, conversions, converter

#: File suffixes read as netCDF.
NETCDF_SUFFIXES = (".nc", ".nc4", ".netcdf", ".cdf")
#: Names a time variable goes by when it is not its dimension's coordinate.
_TIME_NAMES = ("time", "t", "timestamp", "time_s", "datetime", "date_time", "seconds")
#: Seconds per unit of a CF ``UNIT since DATE`` clock.
_SECONDS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0,
            "d": 86400.0}
#: Contract columns per measured quantity and axis (None: a single, axis-less column).
_TARGETS = {
    "rate": {None: "drift_deg_h", **{a: f"drift_{a}_deg_h" for a in "xyz"}},
    "acceleration": {a: f"a{a}_g" for a in "xyz"},
    "field": {a: f"H{a}_uT" for a in "xyz"},
    "temperature": {None: "temperature_C"},
}
#: Words in a thermometer's name that say it is the sensor's own (preferred when several).
_SENSOR_WORDS = ("gyro", "imu", "sensor", "die", "internal", "chip")


def is_netcdf(path: Path) -> bool:
    return path.suffix.lower() in NETCDF_SUFFIXES


def read_netcdf(path: Path, maps: tuple[ColumnMap, ...] = ()) -> LogTable:
    """The log table of a netCDF file (see the module docstring)."""
    dataset = _open(path)
    try:
        time_dim, time_name = _time_dimension(dataset, path, maps)
        columns, units, origins = _columns(dataset, time_dim, time_name)
        clock_unit = next((m.unit for m in maps if m.target == "time_s"), None)
        time_s = _clock(dataset[time_name], path, clock_unit)
    finally:
        dataset.close()
    # the clock is decoded here (its map's unit, if any, read above)
    maps = _resolve_maps(tuple(m for m in maps if m.target != "time_s"), columns, units, path)
    mapped = {m.target for m in maps}
    used = {m.source for m in maps}
    recognised = _recognise({c: u for c, u in units.items() if c not in used}, mapped, path)
    raw = {"time_s": time_s}
    picked = {"format": "netCDF", "time": f"{time_name} (dimension {time_dim})"}
    for target, (source, unit) in recognised.items():
        raw[target] = converter(target, unit)(columns[source])
        picked[target] = f"{origins[source]} ({units[source]})"
    taken = {source for source, _ in recognised.values()}
    for name, values in columns.items():  # the rest, for --map and --extra-columns
        if name not in taken:
            raw.setdefault(name, values)
    n = time_s.size
    return LogTable(path, tuple(raw), raw, n, None, None,
                    comments=tuple(f"{k}: {v}" for k, v in picked.items()), maps=maps,
                    picked=picked)


def _open(path: Path):
    import xarray as xr

    if not path.exists():
        raise GyroidInputError(f"{path}: no such file; check the path")
    import h5py

    engine = "h5netcdf" if h5py.is_hdf5(str(path)) else "scipy"
    try:
        return xr.open_dataset(path, engine=engine, decode_times=False,
                               decode_timedelta=False, mask_and_scale=True)
    except Exception as error:  # noqa: BLE001 - the engines raise many kinds on a bad file
        raise GyroidInputError(f"{path.name}: not a readable netCDF file ({error})") from None


def _time_dimension(dataset, path: Path, maps) -> tuple[str, str]:
    """The time dimension (the longest one data variables run along) and its clock
    variable (``--map time_s=NAME``, the dimension's coordinate, or a time-named one)."""
    chosen = next((m.source for m in maps if m.target == "time_s"), None)
    if chosen is not None:
        if chosen not in dataset.variables or dataset[chosen].ndim != 1:
            raise GyroidInputError(f"{path.name}: --map time_s={chosen}: no one-dimensional "
                                   f"variable {chosen!r}; the file has "
                                   f"{', '.join(map(str, dataset.variables))}")
        return str(dataset[chosen].dims[0]), chosen
    sizes = {str(d): int(s) for d, s in dataset.sizes.items()
             if any(d in v.dims for v in dataset.data_vars.values())}
    if not sizes:
        raise GyroidInputError(f"{path.name}: the file holds no data variables")
    time_dim = max(sizes, key=lambda d: (sizes[d], d.lower() in _TIME_NAMES))
    if time_dim in dataset.variables:
        return time_dim, time_dim
    for name in dataset.variables:
        if str(name).lower() in _TIME_NAMES and dataset[name].dims == (time_dim,):
            return time_dim, str(name)
    raise GyroidInputError(f"{path.name}: no time variable along dimension {time_dim!r}; name "
                           "the clock with --map time_s=VARIABLE[:UNIT]")


def _columns(dataset, time_dim: str, time_name: str):
    """Every numeric variable along the time dimension as columns (file units), their
    ``units`` attributes, and where each came from (for messages and axes.json)."""
    columns: dict[str, np.ndarray] = {}
    units: dict[str, str | None] = {}
    origins: dict[str, str] = {}
    for name, variable in dataset.variables.items():
        name = str(name)
        if name == time_name or time_dim not in variable.dims:
            continue
        if variable.dtype.kind not in "fiu":
            continue
        values = variable.transpose(time_dim, ...).values.astype(float)
        values = values.reshape(values.shape[0], -1)
        labels = _axis_labels(dataset, variable, time_dim, values.shape[1])
        for k, label in enumerate(labels):
            column = name if label is None else f"{name}_{label}"
            columns[column] = values[:, k]
            units[column] = variable.attrs.get("units")
            origins[column] = name if label is None else f"{name}[{label}]"
    return columns, units, origins


def _axis_labels(dataset, variable, time_dim: str, width: int) -> Sequence[str | None]:
    others = [d for d in variable.dims if d != time_dim]
    if not others:
        return [None]
    if len(others) == 1:
        dim = others[0]
        if dim in dataset.coords and dataset[dim].ndim == 1:
            labels = [str(v.decode() if isinstance(v, bytes) else v).strip()
                      for v in dataset[dim].values]
            if len(set(labels)) == width and all(re.fullmatch(r"\w+", v) for v in labels):
                return labels
        if width == 3:
            return ["x", "y", "z"]
    return [str(k + 1) for k in range(width)]


def _clock(variable, path: Path, unit: str | None = None) -> np.ndarray:
    """Seconds from a time variable: CF ``UNIT since DATE`` (seconds since 1970 when the
    date reads), a plain time unit (``unit``, a ``--map time_s=VAR:UNIT``'s, else its
    ``units`` attribute), or a datetime64 variable."""
    values = np.asarray(variable.values)
    if values.dtype.kind == "M":
        return values.astype("datetime64[ns]").astype(np.int64) / 1e9
    if unit in _SECONDS:
        return values.astype(float) * _SECONDS[unit]
    unit_text = str(variable.attrs.get("units", "")).strip()
    since = re.fullmatch(r"(\w+)\s+since\s+(.+)", unit_text, flags=re.IGNORECASE)
    if since:
        unit = canonical_unit(since.group(1))
        if unit not in _SECONDS:
            raise GyroidInputError(f"{path.name}: time variable {variable.name!r} has units "
                                   f"{unit_text!r}; gyroid reads s, ms, us, ns, min, h or d "
                                   "since a date")
        return values.astype(float) * _SECONDS[unit] + _epoch_seconds(since.group(2))
    unit = canonical_unit(unit_text) if unit_text else None
    if unit_text and unit not in _SECONDS:
        raise GyroidInputError(f"{path.name}: time variable {variable.name!r} has units "
                               f"{unit_text!r}, not a time; name the clock with --map "
                               "time_s=VARIABLE:UNIT")
    return values.astype(float) * _SECONDS.get(unit or "s", 1.0)


def _epoch_seconds(date: str) -> float:
    """A CF reference date as seconds since 1970 (0 when it does not read as a date: the
    clock is then relative, which is all a fit needs)."""
    text = re.sub(r"\s*(UTC|Z|[+-]00:?00)\s*$", "", date.strip(), flags=re.IGNORECASE)
    text = re.sub(r"\s+", "T", text, count=1)
    try:
        return float(np.datetime64(text, "ns").astype(np.int64)) / 1e9
    except ValueError:
        return 0.0


def _resolve_maps(maps, columns, units, path: Path) -> tuple[ColumnMap, ...]:
    """``--map`` items with ``NAME[label]`` read as the column ``NAME_label`` and, where no
    unit is given, the variable's ``units`` attribute as the unit."""
    out = []
    for m in maps:
        source = re.sub(r"^(.+)\[(\w+)\]$", r"\1_\2", m.source)
        if m.target == "time_s":
            out.append(replace(m, source=source))
            continue
        unit = m.unit
        if unit is None and source in columns and units.get(source):
            unit = canonical_unit(units[source])
            if unit is None or unit not in (conversions(m.target) or {}):
                raise GyroidInputError(
                    f"{path.name}: --map {m.target}={m.source}: the variable's units "
                    f"{units[source]!r} are not a unit of {m.target}; give one with --map "
                    f"{m.target}={m.source}:UNIT")
        out.append(replace(m, source=source, unit=unit))
    return tuple(out)


def _recognise(units, mapped: set[str], path: Path) -> dict[str, tuple[str, str]]:
    """Contract column -> (column, unit) for the columns recognised by their units (the
    recognised ones are then read under the contract's names only)."""
    found: dict[str, list[tuple[str, str]]] = {}
    for column, text in units.items():
        unit = canonical_unit(text)
        kind = quantity(unit)
        if unit is None or kind not in _TARGETS:
            continue
        targets = _TARGETS[kind]
        axis = _axis_of(column) if set(targets) - {None} else None
        target = targets.get(axis) or targets.get(None)
        if target is None and kind == "rate":
            continue
        if target is not None and target not in mapped:
            found.setdefault(target, []).append((column, unit))
    chosen = {}
    for target, candidates in found.items():
        if len(candidates) > 1 and target == "temperature_C":
            own = [c for c in candidates if any(w in c[0].lower() for w in _SENSOR_WORDS)]
            candidates = own if len(own) == 1 else candidates
        if len(candidates) > 1:
            names = ", ".join(c for c, _ in candidates)
            raise GyroidInputError(f"{path.name}: several variables could be {target} "
                                   f"({names}); choose one with --map {target}=VARIABLE")
        chosen[target] = candidates[0]
    axes = [t for t in chosen if re.fullmatch(r"drift_[xyz]_deg_h", t)]
    if "drift_deg_h" in chosen and axes:
        del chosen["drift_deg_h"]  # an axis-less rate beside per-axis ones: not the gyro
    return chosen


def _axis_of(column: str) -> str | None:
    """x, y or z from a column's ending (``gyro_x``, ``gyrX``, ``wz``, ``omega_2``)."""
    match = re.search(r"(?:^|[_\W\d]|(?<=[a-z]))([xyzXYZ123])$", column)
    if match is None:
        return None
    letter = match.group(1).lower()
    return {"1": "x", "2": "y", "3": "z"}.get(letter, letter)
