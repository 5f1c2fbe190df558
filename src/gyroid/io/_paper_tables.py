"""Paper A's printed tables, shipped with gyroid as package data (with their source)."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from importlib import resources

import numpy as np


def _read(name: str) -> tuple[list[dict[str, str]], list[str]]:
    text = resources.files("gyroid.data").joinpath(name).read_text(encoding="utf-8")
    source = [line[1:].strip() for line in text.splitlines() if line.startswith("#")]
    body = "\n".join(line for line in text.splitlines() if not line.startswith("#"))
    return list(csv.DictReader(io.StringIO(body))), source


@dataclass(frozen=True)
class ThermalTable:
    """Paper A's setpoint table: drift deviation and its RMS at each thermostat setpoint."""

    setpoint_C: np.ndarray
    dw_deg_h: np.ndarray
    sigma_deg_h: np.ndarray
    source: tuple[str, ...]


def paper_a_thermal_table() -> ThermalTable:
    rows, source = _read("paper_a_thermal_table.csv")
    return ThermalTable(
        setpoint_C=np.array([float(r["setpoint_C"]) for r in rows]),
        dw_deg_h=np.array([float(r["dw_deg_h"]) for r in rows]),
        sigma_deg_h=np.array([float(r["sigma_deg_h"]) for r in rows]),
        source=tuple(source),
    )


def paper_a_thermal_coefficients() -> dict[str, float]:
    """Paper A's printed thermal coefficients (w1 negative, wD taken positive)."""
    rows, _ = _read("paper_a_coefficients.csv")
    return {r["parameter"]: float(r["value"]) for r in rows}


def paper_a_magnetic_coefficients() -> dict[tuple[int, int], dict[str, float]]:
    """Paper A's magnetic coefficients by (device, test), deg/h per 100 uT."""
    rows, _ = _read("paper_a_magnetic_coefficients.csv")
    return {
        (int(r["device"]), int(r["test"])): {k: float(r[k]) for k in ("wx", "wy", "wz")}
        for r in rows
    }


def paper_a_table_log():
    """Paper A's setpoint table as a bench log (one row per setpoint, sigma as printed),
    so that gyroid's fits run on the paper's only real measurements."""
    from gyroid.io._logs import BenchLog

    table = paper_a_thermal_table()
    return BenchLog(
        columns={
            "time_s": np.arange(table.setpoint_C.size, dtype=float),
            "drift_deg_h": table.dw_deg_h,
            "temperature_C": table.setpoint_C,
            "sigma_deg_h": table.sigma_deg_h,
        },
        source="paper A setpoint table",
        comments=table.source,
    )
