"""Shared problems for the tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gyroid.bench import MagneticProtocol, ThermalProtocol
from gyroid.logs import bench_log_text
from gyroid.noise import GyroNoise

QUIET = GyroNoise(arw_deg_rt_h=0.0, temperature_noise_C=0.0, field_noise_uT=0.0)
#: A short thermal schedule (3 setpoints, 10 s samples) for fast tests.
SHORT_THERMAL = ThermalProtocol(
    setpoints_C=(31.0, 40.0, 55.0),
    initial_min=20.0,
    transition_min=60.0,
    soak_min=30.0,
    sample_s=10.0,
)
SHORT_MAGNETIC = MagneticProtocol(dwell_s=60.0, sample_s=5.0, turn_gap_s=100.0)


def write_log(path: Path, columns: dict[str, np.ndarray]) -> Path:
    path.write_text(bench_log_text(columns))
    return path
