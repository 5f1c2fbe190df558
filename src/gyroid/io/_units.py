"""Vendors' columns and units (``--map CONTRACT_COLUMN=LOG_COLUMN[:UNIT]``): which log column
stands for which contract column, and the conversion of its unit to the contract's."""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from gyroid.errors import GyroidInputError

_DEG_H_PER = {"deg/h": 1.0, "dph": 1.0, "deg/s": 3600.0, "dps": 3600.0,
              "mdps": 3.6, "mdeg/s": 3.6, "rad/s": 3600.0 * 180.0 / math.pi,
              "mrad/s": 3.6 * 180.0 / math.pi, "deg/min": 60.0, "rad/h": 180.0 / math.pi}
_UT_PER = {"uT": 1.0, "T": 1e6, "mT": 1e3, "nT": 1e-3, "G": 100.0, "mG": 0.1, "gauss": 100.0}
_S_PER = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}
_G_PER = {"g": 1.0, "mg": 1e-3, "m/s^2": 1.0 / 9.80665, "m/s2": 1.0 / 9.80665}
_DEG_PER = {"deg": 1.0, "rad": 180.0 / math.pi, "mrad": 0.18 / math.pi}


def _scale(table: dict[str, float], target: float):
    return {unit: (lambda v, f=factor / target: v * f) for unit, factor in table.items()}


_TEMPERATURE = {"degC": lambda v: v, "C": lambda v: v, "K": lambda v: v - 273.15,
                "degF": lambda v: (v - 32.0) * 5.0 / 9.0, "F": lambda v: (v - 32.0) * 5.0 / 9.0}
#: Per contract column: its unit conversions (unit -> function to the contract's unit).
CONVERSIONS = {
    "time_s": _scale(_S_PER, 1.0) | {"datetime": lambda v: v},  # date-times parsed on read
    "drift_deg_h": _scale(_DEG_H_PER, 1.0),
    "sigma_deg_h": _scale(_DEG_H_PER, 1.0),
    "temperature_C": _TEMPERATURE,
    **{name: _scale(_UT_PER, 1.0) for name in ("Hx_uT", "Hy_uT", "Hz_uT")},
    **{name: _scale(_G_PER, 1.0) for name in ("ax_g", "ay_g", "az_g")},
    "roll_rate_deg_s": _scale(_DEG_H_PER, 3600.0),
    "gs_rate_deg_s": _scale(_DEG_H_PER, 3600.0),
    "gs_angle_deg": _scale(_DEG_PER, 1.0),
}


#: A gyro axis's drift column (``drift_x_deg_h``): one per axis of a log with several.
AXIS_COLUMN = re.compile(r"^drift_([a-z0-9]+)_deg_h$")


def conversions(target: str) -> dict[str, Callable[[np.ndarray], np.ndarray]] | None:
    """The unit conversions of a contract column (an axis's drift column included)."""
    if AXIS_COLUMN.match(target):
        return CONVERSIONS["drift_deg_h"]
    return CONVERSIONS.get(target)


def converter(target: str, unit: str) -> Callable[[np.ndarray], np.ndarray]:
    """The function taking ``unit`` to the contract column ``target``'s unit; a clear error
    where it is not one of that column's units."""
    table = conversions(target)
    if table is None or unit not in table:
        raise GyroidInputError(f"{unit!r} is not a unit of {target}{unit_list(target)}")
    return table[unit]


def unit_list(target: str) -> str:
    """`` (units a, b, ...)``: every unit ``--map`` converts to a contract column's, for a
    message; empty for a column without conversions."""
    table = conversions(target)
    return f" (units {', '.join(table)})" if table else ""


def axis_column(axis: str) -> str:
    return f"drift_{axis}_deg_h"


@dataclass(frozen=True)
class ColumnMap:
    """``--map CONTRACT_COLUMN=LOG_COLUMN[:UNIT]``."""

    target: str
    source: str
    unit: str | None = None

    def convert(self, values: np.ndarray) -> np.ndarray:
        if self.unit is None:
            return values
        return converter(self.target, self.unit)(values)


def parse_column_maps(items: Iterable[str]) -> tuple[ColumnMap, ...]:
    """Parse ``CONTRACT=LOG[:UNIT]`` items, refusing unknown columns and units."""
    maps: list[ColumnMap] = []
    for item in items:
        target, sep, rest = item.partition("=")
        target, rest = target.strip(), rest.strip()
        if not sep or not target or not rest:
            raise GyroidInputError(f"--map {item!r}: write CONTRACT_COLUMN=LOG_COLUMN[:UNIT]")
        units = conversions(target)
        if units is None:
            raise GyroidInputError(f"--map {item!r}: {target!r} is not one of gyroid's columns; "
                                   f"use one of {', '.join(CONVERSIONS)} or drift_AXIS_deg_h")
        source, _, unit = rest.rpartition(":") if ":" in rest else (rest, "", "")
        unit = unit.strip() or None
        if unit is not None and unit not in units:
            raise GyroidInputError(f"--map {item!r}: unknown unit {unit!r} for {target}; use "
                                   f"one of {', '.join(units)}")
        if any(m.target == target for m in maps):
            raise GyroidInputError(f"--map names {target} twice")
        maps.append(ColumnMap(target, source.strip(), unit))
    return tuple(maps)
