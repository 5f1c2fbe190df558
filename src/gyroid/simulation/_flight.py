"""Flights of paper B's vehicle with known truth, written as roll logs (docs/formats.md section 4).

The roll rate follows a profile (constant, a ramp, or a slow oscillation about a mean); the
SINS roll gyro, the gyrostabiliser's MEMS gyro and its encoder are simulated with
:mod:`gyroid.models._roll`; the environment (temperature rising through the flight, the Earth's
field turning in body axes as the vehicle rolls) is logged, and the SINS gyro's bias may
follow a FOG drift model in that environment.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import jax.numpy as jnp
import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import T0_C, inputs_from_arrays
from gyroid.models._roll import MEMS_SATURATION_DEG_S, Flight, LoopResult, RollParams, run_loop

#: Paper B's values: SiIMU02 roll gyro (SF error 600 ppm, bias 100 deg/h), GYPRO4300 MEMS
#: (bias 12.2 deg/h, SF error 280 ppm), encoder 20 arc-min (0.33 deg).
PAPER_B_PARAMS = {"D0": 100.0 / 3600.0, "D1": 600e-6, "D0gs": 12.2 / 3600.0, "D1gs": 280e-6,
                  "Denc": 0.33, "D2": 0.0}


@dataclass(frozen=True)
class FlightProfile:
    """How the flight goes."""

    duration_s: float = 120.0
    sample_s: float = 0.01  # 100 Hz log
    period_s: float = 5.0  # correction period dt
    roll: str = "oscillating"  # constant | ramp | oscillating
    roll_rate_deg_s: float = 1800.0  # constant rate, ramp start, or oscillation mean
    roll_rate_end_deg_s: float = 3600.0  # ramp end
    roll_swing_deg_s: float = 900.0  # oscillation amplitude
    roll_swing_period_s: float = 40.0
    overload_fraction: float = 0.0  # w_H = fraction * w (Sandia: ~0.1 at 3600 deg/s)
    gs_capacity_deg_s: float | None = None  # or: the GS cancels up to this rate, w_H = excess
    mems_saturation_deg_s: float = MEMS_SATURATION_DEG_S
    sins_noise_deg_s: float = 0.02  # white, per sample
    gs_noise_deg: float = 0.01  # encoder read-out noise
    mems_noise_deg_s: float = 0.05  # noise of the logged stabiliser MEMS output
    encoder_phase_rad: float = 0.7
    start_temperature_C: float = T0_C
    temperature_rise_C: float = 4.0  # over the flight, smooth
    earth_field_uT: tuple[float, float] = (20.0, 45.0)  # along the roll axis, across it
    feedback: bool = False

    def roll_rate(self, time_s: np.ndarray) -> np.ndarray:
        if self.roll == "constant":
            return np.full(time_s.shape, self.roll_rate_deg_s)
        if self.roll == "ramp":
            frac = time_s / self.duration_s
            return self.roll_rate_deg_s + frac * (self.roll_rate_end_deg_s - self.roll_rate_deg_s)
        if self.roll == "oscillating":
            phase = 2.0 * np.pi * time_s / self.roll_swing_period_s
            return self.roll_rate_deg_s + self.roll_swing_deg_s * np.sin(phase)
        raise GyroidInputError(f"roll profile must be constant, ramp or oscillating: {self.roll}")


@dataclass(frozen=True)
class SimulatedFlight:
    """A simulated roll log, its truth, and the loop's full result."""

    columns: dict[str, np.ndarray]
    truth: dict
    loop: LoopResult = field(repr=False)


def environment(time_s: np.ndarray, duration_s: float, start_C: float, rise_C: float,
                earth_field_uT: tuple[float, float], roll_angle_deg: np.ndarray):
    """A flight's temperature (degC), its rate (degC/h) and the Earth's field in the gyro's
    axes (uT, (n, 3)): the temperature rises smoothly by ``rise_C`` over the flight
    (3 f^2 - 2 f^3, zero rate at both ends); the field's cross component turns with the roll
    angle (0 for a gyro on the stabilised platform)."""
    frac = time_s / duration_s
    temperature = start_C + rise_C * (3 * frac**2 - 2 * frac**3)
    rate = rise_C * 6 * frac * (1 - frac) / duration_s * 3600.0
    along, across = earth_field_uT
    angle = np.deg2rad(roll_angle_deg)
    field_uT = np.column_stack([np.full(time_s.shape, along), across * np.cos(angle),
                                -across * np.sin(angle)])
    return temperature, rate, field_uT


def uncompensated(profile: FlightProfile, rate: np.ndarray) -> np.ndarray:
    """The rate the stabiliser's platform is left with, deg/s."""
    excess = np.zeros_like(rate)
    if profile.gs_capacity_deg_s is not None:
        excess = np.sign(rate) * np.maximum(np.abs(rate) - profile.gs_capacity_deg_s, 0.0)
    return profile.overload_fraction * rate + excess


def simulate_flight(
    *,
    params: dict[str, float] | None = None,
    profile: FlightProfile | None = None,
    drift_model: DriftModel | None = None,
    drift_params: dict[str, float] | None = None,
    seed: int = 0,
) -> SimulatedFlight:
    """Simulate a flight. ``drift_model``/``drift_params`` (deg/h) add a FOG drift history
    in the flight's environment to the SINS gyro's bias."""
    profile = profile or FlightProfile()
    values = dict(PAPER_B_PARAMS | (params or {}))
    unknown = set(values) - set(PAPER_B_PARAMS)
    if unknown:
        raise GyroidInputError(f"unknown roll parameter {sorted(unknown)[0]!r}; known: "
                               f"{', '.join(PAPER_B_PARAMS)}")
    rng = np.random.default_rng(seed)
    n = int(round(profile.duration_s / profile.sample_s))
    time_s = profile.sample_s * (np.arange(n) + 1.0)
    rate = profile.roll_rate(time_s)
    angle = np.cumsum(rate) * profile.sample_s
    temperature, temperature_rate, field_uT = environment(
        time_s, profile.duration_s, profile.start_temperature_C, profile.temperature_rise_C,
        profile.earth_field_uT, angle)
    drift = np.zeros(n)
    if drift_model is not None:
        inputs = inputs_from_arrays(time_s, temperature, temperature_rate, field_uT,
                                    origin_s=0.0)
        drift = np.asarray(drift_model({k: jnp.asarray(v)
                                        for k, v in (drift_params or {}).items()},
                                       inputs)) / 3600.0
    flight = Flight(
        roll_rate_deg_s=jnp.asarray(rate),
        uncompensated_deg_s=jnp.asarray(uncompensated(profile, rate)),
        sins_drift_deg_s=jnp.asarray(drift),
        sins_noise_deg_s=jnp.asarray(rng.normal(0.0, profile.sins_noise_deg_s, n)),
        gs_noise_deg=jnp.asarray(rng.normal(0.0, profile.gs_noise_deg, n)),
        sample_s=profile.sample_s,
        period_s=profile.period_s,
        mems_range_deg_s=profile.mems_saturation_deg_s,
        feedback=profile.feedback,
    )
    loop = run_loop(RollParams(**values, encoder_phase=profile.encoder_phase_rad), flight)
    m = loop.time_s.shape[0]
    columns = {
        "time_s": time_s[:m],
        "roll_rate_deg_s": np.asarray(loop.sins_rate_deg_s),
        "gs_angle_deg": np.asarray(loop.gs_angle_deg),
        "gs_rate_deg_s": np.asarray(loop.gs_rate_deg_s)
        + rng.normal(0.0, profile.mems_noise_deg_s, m),
        "temperature_C": temperature[:m],
        "Hx_uT": field_uT[:m, 0],
        "Hy_uT": field_uT[:m, 1],
        "Hz_uT": field_uT[:m, 2],
    }
    truth = {
        "parameters": values,
        "profile": asdict(profile),
        "seed": seed,
        "true_roll_rate_mean_deg_s": float(rate.mean()),
        "dK": {"mean": float(np.mean(loop.dK)), "per_period": np.asarray(loop.dK).tolist()},
        "final_angle_error_deg": float(loop.angle_error_deg[-1]),
        "uncorrected_final_angle_error_deg": float(loop.uncorrected_error_deg[-1]),
        "drift_model": None if drift_model is None else {"terms": list(drift_model.terms),
                                                         "parameters": drift_params},
    }
    return SimulatedFlight(columns=columns, truth=truth, loop=loop)


ROLL_COLUMNS = ("time_s", "roll_rate_deg_s", "gs_angle_deg", "gs_rate_deg_s", "temperature_C",
                "Hx_uT", "Hy_uT", "Hz_uT")


def roll_log_text(columns: dict[str, np.ndarray], comments=()) -> str:
    """Contract section 4 CSV text."""
    names = [c for c in ROLL_COLUMNS if c in columns]
    lines = [f"# {c}" for c in comments]
    lines.append(",".join(names))
    data = np.column_stack([np.asarray(columns[c], dtype=float) for c in names])
    lines += [",".join(f"{v:.12g}" for v in row) for row in data]
    return "\n".join(lines) + "\n"
