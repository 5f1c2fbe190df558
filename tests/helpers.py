"""Shared problems for the tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gyroid.io import bench_log_text
from gyroid.simulation import GyroNoise, MagneticProtocol, ThermalProtocol

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


# ----- stress logs: other gyro grades and shapes than paper A's bench ------------------------


def mems_burst_log(seed: int, *, hours: float = 3.0, wander_deg_h: float = 0.0
                   ) -> tuple[dict[str, np.ndarray], dict]:
    """A consumer MEMS gyro in a thermal-vacuum test: bias of -1500 deg/h, 30 deg/h/degC,
    the temperature falling steadily from 40 to 0 degC, 5 s bursts at 50 Hz every 5 min,
    white noise of 200 deg/h (like the real log in issue 13); ``wander_deg_h``: the sd of
    an independent bias offset per burst (the real log's wander between bursts)."""
    rng = np.random.default_rng(seed)
    starts = np.arange(0.0, hours * 3600.0, 300.0)
    time_s = (starts[:, None] + np.arange(250)[None, :] / 50.0).ravel()
    temperature = 40.0 - 40.0 * time_s / (hours * 3600.0)
    truth = {"w0": -1500.0, "w1": 30.0, "w2": 0.5}
    t = temperature - 21.0
    drift = truth["w0"] + truth["w1"] * t + truth["w2"] * t**2
    drift = drift + np.repeat(wander_deg_h * rng.standard_normal(starts.size), 250)
    columns = {"time_s": time_s, "drift_deg_h": drift + 200.0 * rng.standard_normal(time_s.size),
               "temperature_C": temperature + 0.05 * rng.standard_normal(time_s.size)}
    return columns, truth


def fast_ramp_log(seed: int, *, ramp_min: float = 15.0, hours: float = 8.0
                  ) -> tuple[dict[str, np.ndarray], dict]:
    """A FOG on 15-minute ramps of 10 degC between holds of the same length, 1 Hz, white
    noise of 0.05 deg/h given as sigma_deg_h (issue 13's second case)."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(0.0, hours * 3600.0)
    period = 4 * ramp_min * 60.0
    phase = (time_s % period) / (ramp_min * 60.0)  # 0-1 up, 1-2 hold, 2-3 down, 3-4 hold
    shape = np.clip(phase, 0, 1) - np.clip(phase - 2.0, 0, 1)
    temperature = 25.0 + 10.0 * shape
    rate = np.where(phase < 1, 1.0, np.where((phase >= 2) & (phase < 3), -1.0, 0.0))
    rate_C_h = rate * 10.0 / (ramp_min / 60.0)
    truth = {"w0": 1.2, "w1": -0.1, "w2": 0.004, "wD": 2.0}
    t = temperature - 21.0
    drift = truth["w0"] + truth["w1"] * t + truth["w2"] * t**2 + truth["wD"] * rate_C_h
    columns = {"time_s": time_s, "drift_deg_h": drift + 0.05 * rng.standard_normal(time_s.size),
               "temperature_C": temperature + 0.01 * rng.standard_normal(time_s.size),
               "sigma_deg_h": np.full(time_s.size, 0.05)}
    return columns, truth


def weak_field_log(seed: int, *, hours: float = 4.0) -> tuple[dict[str, np.ndarray], dict]:
    """Magnetic terms on a log whose field hardly varies (+/-2 uT, slowly), with correlated
    (Gauss-Markov, 0.3 deg/h, 1800 s) and white noise (issue 13's fourth case)."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(0.0, hours * 3600.0, 2.0)
    phi = np.exp(-2.0 / 1800.0)
    gm = np.empty(time_s.size)
    gm[0] = 0.3 * rng.standard_normal()
    shocks = 0.3 * np.sqrt(1 - phi**2) * rng.standard_normal(time_s.size)
    for i in range(1, time_s.size):
        gm[i] = phi * gm[i - 1] + shocks[i]
    span = hours * 3600.0
    field = {f"H{a}_uT": 2.0 * np.sin(2 * np.pi * time_s / span * k + k)
             for k, a in enumerate("xyz", start=1)}
    drift = 1.0 + gm + 0.3 * rng.standard_normal(time_s.size)
    return {"time_s": time_s, "drift_deg_h": drift, **field}, {"w0": 1.0}
