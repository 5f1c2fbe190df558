"""Simulators of paper A's two benches, producing contract logs with known truth.

* Thermal bench: the gyro's temperature is driven from the lab temperature through the
  thermostat setpoints 31...55 degC in smooth transitions (error-function steps: a
  thermostat's heater and the case's thermal inertia give a smooth approach) followed by
  soaks; 1 Hz logging; optional window averages as in the paper.
* Magnetic bench: Helmholtz-coil sweeps along each axis, 0 -> +300 -> -300 -> 0 uT in 50 uT
  steps with a 180 s dwell, OX then OY then OZ (after a 90 deg azimuth turn, logged as a
  gap), the lab's field compensated, temperature at the lab's with a slow wander.

The drift is the sum of the chosen effects evaluated on the *true* inputs (true temperature
and its analytic rate, true field) plus gyro noise; the log holds the *measured* inputs
(thermometer and magnetometer noise added).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import ClassVar, Protocol

import jax.numpy as jnp
import numpy as np
from scipy.special import erf

from gyroid.errors import GyroidInputError
from gyroid.io._logs import BenchLog
from gyroid.models._change_signs import field_change_sign, temperature_change_sign
from gyroid.models._derived import HYSTERESIS_DEADBAND_UT
from gyroid.models._drift import DriftModel
from gyroid.models._effects import EFFECTS
from gyroid.models._inputs import ACCEL_COLUMNS, FIELD_COLUMNS, T0_C, inputs_from_arrays
from gyroid.models._terms import PRESETS
from gyroid.simulation._noise import GyroNoise, rate_noise
from gyroid.simulation._truth import resolve_truth, truth_comments, truth_record

#: Paper A's thermal coefficients (w1 negative, wD taken positive: see the package data).
PAPER_A_THERMAL = {"w0": 1.197, "w1": -0.108, "w2": 0.004, "wD": 1.997}
#: Paper A's device 2, test 1, deg/h per 100 uT.
PAPER_A_DEVICE_2 = {"wx": -0.037, "wy": -0.576, "wz": -0.253}
#: g-sensitivities of the overload bench's default truth, deg/h per g (paper A gives no
#: values; FOG-sized, different on each axis).
OVERLOAD_SENSITIVITIES = {"nx": 0.35, "ny": -0.2, "nz": 0.5}


@dataclass(frozen=True)
class TrueInputs:
    """A bench schedule's sample times (s) and true inputs: temperature (degC) and its
    exact rate (degC/h), and the field (uT) or specific force (g), (n, 3), where the bench
    sets them."""

    time_s: np.ndarray
    temperature_C: np.ndarray
    rate_C_h: np.ndarray
    field_uT: np.ndarray | None = None
    accel_g: np.ndarray | None = None


class BenchSchedule(Protocol):
    """What a bench's protocol (a frozen dataclass, recorded in the truth) gives the
    simulator."""

    __dataclass_fields__: ClassVar[dict]

    @property
    def sample_s(self) -> float: ...

    def true_inputs(self) -> TrueInputs: ...


@dataclass(frozen=True)
class ThermalProtocol:
    """Thermal bench schedule (paper A: setpoints 31...55 degC in 5 degC steps, readings
    after 40 min, 60 s averages)."""

    lab_C: float = T0_C
    setpoints_C: tuple[float, ...] = (31.0, 35.0, 40.0, 45.0, 50.0, 55.0)
    initial_min: float = 20.0  # at lab temperature before the first heating
    transition_min: float = 60.0  # each setpoint change: an erf step, +/-3 sd in this time
    soak_min: float = 40.0  # settled at each setpoint
    return_to_lab: bool = False  # a final transition back to the lab temperature
    sample_s: float = 1.0
    lab_field_uT: tuple[float, float, float] = (17.0, 0.0, -48.0)

    @property
    def duration_s(self) -> float:
        steps = len(self.setpoints_C) + int(self.return_to_lab)
        return 60.0 * (self.initial_min + steps * (self.transition_min + self.soak_min))

    def stretched(self, hours: float | None = None, rate_hz: float | None = None
                  ) -> ThermalProtocol:
        """The same schedule lasting ``hours`` (every phase scaled alike) and sampled at
        ``rate_hz``: long and fast logs (``gyroid simulate --hours --rate-hz``)."""
        factor = 1.0 if hours is None else hours * 3600.0 / self.duration_s
        return replace(self, initial_min=self.initial_min * factor,
                       transition_min=self.transition_min * factor,
                       soak_min=self.soak_min * factor,
                       sample_s=self.sample_s if rate_hz is None else 1.0 / rate_hz)

    def levels_C(self) -> tuple[float, ...]:
        levels = tuple(self.setpoints_C)
        return levels + ((self.lab_C,) if self.return_to_lab else ())

    def segment_starts_s(self) -> np.ndarray:
        """Start time of each transition, s."""
        step = 60.0 * (self.transition_min + self.soak_min)
        return 60.0 * self.initial_min + step * np.arange(len(self.levels_C()))

    def true_inputs(self) -> TrueInputs:
        """The schedule's sample times and true inputs (the lab's field throughout)."""
        time_s = np.arange(0.0, self.duration_s, self.sample_s)
        temperature, rate = self.temperature(time_s)
        field_uT = np.tile(np.asarray(self.lab_field_uT, dtype=float), (time_s.size, 1))
        return TrueInputs(time_s, temperature, rate, field_uT=field_uT)

    def temperature(self, time_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """True temperature, degC, and its rate, degC/h, at ``time_s``."""
        temperature = np.full(time_s.shape, self.lab_C)
        rate = np.zeros(time_s.shape)
        width_s = 60.0 * self.transition_min / 6.0
        previous = self.lab_C
        for start, level in zip(self.segment_starts_s(), self.levels_C(), strict=True):
            centre = start + 30.0 * self.transition_min
            z = (time_s - centre) / width_s
            temperature += (level - previous) * 0.5 * (1.0 + erf(z / np.sqrt(2.0)))
            density = np.exp(-0.5 * z**2) / (width_s * np.sqrt(2.0 * np.pi))
            rate += (level - previous) * density * 3600.0
            previous = level
        return temperature, rate

    def reading_windows_s(self, window_s: float = 60.0) -> list[tuple[float, float, float]]:
        """(level degC, start s, end s) of the reading at the end of each soak and of the
        lab-temperature reading before heating."""
        out = [(self.lab_C, 60.0 * self.initial_min - window_s, 60.0 * self.initial_min)]
        step = 60.0 * (self.transition_min + self.soak_min)
        for start, level in zip(self.segment_starts_s(), self.levels_C(), strict=True):
            end = start + step
            out.append((level, end - window_s, end))
        return out


@dataclass(frozen=True)
class MagneticProtocol:
    """Helmholtz-coil schedule (paper A): per axis 0 -> +300 -> -300 -> 0 uT in 50 uT steps,
    180 s at each value; OX, then OY, then OZ after a 90 deg azimuth turn."""

    amplitude_uT: float = 300.0
    step_uT: float = 50.0
    dwell_s: float = 180.0
    axes: tuple[str, ...] = ("x", "y", "z")
    turn_gap_s: float = 600.0  # no samples while the gyro is turned before the OZ sweep
    lab_C: float = T0_C
    temperature_wander_C: float = 0.2  # amplitude of a slow lab-temperature wander
    wander_period_h: float = 3.0
    sample_s: float = 1.0

    @property
    def duration_s(self) -> float:
        gap = self.turn_gap_s if "z" in self.axes[1:] else 0.0
        return len(self.axes) * self.sweep_levels_uT().size * self.dwell_s + gap

    def stretched(self, hours: float | None = None, rate_hz: float | None = None
                  ) -> MagneticProtocol:
        """The same sweeps lasting ``hours`` (dwell and turn scaled alike) and sampled at
        ``rate_hz``."""
        factor = 1.0 if hours is None else hours * 3600.0 / self.duration_s
        return replace(self, dwell_s=self.dwell_s * factor, turn_gap_s=self.turn_gap_s * factor,
                       sample_s=self.sample_s if rate_hz is None else 1.0 / rate_hz)

    def sweep_levels_uT(self) -> np.ndarray:
        """Field values of one axis sweep, in order: 0, 50, ..., 300, 250, ..., -300, ..., 0."""
        n = int(round(self.amplitude_uT / self.step_uT))
        up = np.arange(0, n + 1)
        down = np.arange(n - 1, -n - 1, -1)
        back = np.arange(-n + 1, 1)
        return self.step_uT * np.concatenate([up, down, back]).astype(float)

    def true_inputs(self) -> TrueInputs:
        """The sweeps' sample times and true inputs (the lab's wandering temperature)."""
        time_s, field_uT = self.schedule()
        temperature, rate = lab_wander(time_s, self.lab_C, self.temperature_wander_C,
                                       self.wander_period_h)
        return TrueInputs(time_s, temperature, rate, field_uT=field_uT)

    def schedule(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample times, s, and true field, uT, shape (n, 3)."""
        levels = self.sweep_levels_uT()
        per_level = int(round(self.dwell_s / self.sample_s))
        times, fields = [], []
        clock = 0.0
        for axis in self.axes:
            if axis == "z" and self.turn_gap_s > 0 and times:
                clock += self.turn_gap_s
            k = "xyz".index(axis)
            block = np.zeros((levels.size * per_level, 3))
            block[:, k] = np.repeat(levels, per_level)
            times.append(clock + self.sample_s * np.arange(block.shape[0]))
            fields.append(block)
            clock = times[-1][-1] + self.sample_s
        return np.concatenate(times), np.concatenate(fields)


@dataclass(frozen=True)
class SimulatedBench:
    """A simulated log with its truth."""

    log: BenchLog
    truth: dict
    true_drift_deg_h: np.ndarray = field(repr=False)


def simulate_bench(
    bench: str,
    protocol: BenchSchedule,
    base: Mapping[str, float],
    *,
    effects: Mapping[str, Mapping[str, float]] | None,
    noise: GyroNoise | None,
    seed: int,
    average_s: float | None,
    t0_C: float,
    say: Callable[[str], None] | None,
    detail: str = "",
) -> SimulatedBench:
    """A log of ``bench`` run to ``protocol``: the drift of the truth ``base`` (with
    ``effects`` switched on) on the true inputs, plus ``noise`` (default :class:`GyroNoise`),
    and the inputs as measured; ``say`` is told what is simulated (with ``detail``) once
    the truth is checked."""
    noise = noise or GyroNoise()
    terms, values = resolve_truth(dict(base), effects)
    true = protocol.true_inputs()
    if say is not None:
        say(f"simulating the {bench} bench ({true.time_s.size} rows{detail}) ...")
    time_s, temperature_C, rate_C_h = true.time_s, true.temperature_C, true.rate_C_h
    field_uT, accel_g, sample_s = true.field_uT, true.accel_g, protocol.sample_s
    rng = np.random.default_rng(seed)
    sign = None if field_uT is None else np.column_stack(
        [field_change_sign(field_uT[:, k], HYSTERESIS_DEADBAND_UT) for k in range(3)]
    )
    model = DriftModel(terms=terms)
    simulated = {"temperature_C", *(FIELD_COLUMNS if field_uT is not None else ()),
                 *(ACCEL_COLUMNS if accel_g is not None else ())}
    lacking = [(t, c) for t in terms for c in EFFECTS[t].columns if c not in simulated]
    if lacking:
        raise GyroidInputError(f"effect {lacking[0][0]!r} reads {lacking[0][1]}, which the "
                               f"{bench} bench does not simulate; choose a bench that does")
    true_inputs = inputs_from_arrays(time_s, temperature_C, rate_C_h, field_uT, sign, t0_C=t0_C,
                                     accel_g=accel_g,
                                     temperature_sign=temperature_change_sign(temperature_C))
    params = {name: jnp.asarray(values[name]) for name in model.parameter_names}
    true_drift = np.asarray(model(params, true_inputs))
    n = time_s.size
    # Independent streams, in a fixed order, so each noise source is reproducible.
    gyro = rate_noise(rng, n, sample_s, noise)
    thermometer = rng.standard_normal(n) * noise.temperature_noise_C
    magnetometer = rng.standard_normal((n, 3)) * noise.field_noise_uT
    columns = {
        "time_s": time_s,
        "drift_deg_h": true_drift + gyro,
        "temperature_C": temperature_C + thermometer,
    }
    if field_uT is not None:
        for k, name in enumerate(FIELD_COLUMNS):
            columns[name] = field_uT[:, k] + magnetometer[:, k]
    if accel_g is not None:  # drawn last: the other streams stay those of a log without it
        accelerometer = rng.standard_normal((n, 3)) * noise.accel_noise_g
        for k, name in enumerate(ACCEL_COLUMNS):
            columns[name] = accel_g[:, k] + accelerometer[:, k]
    if average_s:
        columns = window_average(columns, average_s)
    truth = truth_record(bench, model, values, noise, sample_s, asdict(protocol), average_s,
                         seed, t0_C)
    comments = truth_comments(truth)
    log = BenchLog(columns=columns, source=f"<simulated {bench} bench>", comments=comments)
    return SimulatedBench(log=log, truth=truth, true_drift_deg_h=true_drift)


def window_average(columns: Mapping[str, np.ndarray], window_s: float) -> dict[str, np.ndarray]:
    """Average every column over consecutive ``window_s`` windows (paper A's 60 s means).

    ``sigma_deg_h`` of each window is the standard error of its mean drift (sample sd over
    sqrt(count)); windows with fewer than half the full count of samples are dropped.
    """
    time_s = np.asarray(columns["time_s"])
    index = np.floor((time_s - time_s[0]) / window_s).astype(int)
    counts = np.bincount(index)
    keep = np.flatnonzero(counts >= max(2, counts.max() // 2))
    out: dict[str, np.ndarray] = {}
    for name, values in columns.items():
        sums = np.bincount(index, weights=np.asarray(values, dtype=float))
        out[name] = sums[keep] / counts[keep]
    drift = np.asarray(columns["drift_deg_h"])
    mean = out["drift_deg_h"]
    square = np.bincount(index, weights=drift**2)[keep] / counts[keep]
    variance = np.maximum(square - mean**2, 0.0) * counts[keep] / (counts[keep] - 1)
    out["sigma_deg_h"] = np.sqrt(variance / counts[keep])
    return out


def simulate_thermal_bench(
    *,
    parameters: Mapping[str, float] | None = None,
    effects: Mapping[str, Mapping[str, float]] | None = None,
    protocol: ThermalProtocol | None = None,
    noise: GyroNoise | None = None,
    seed: int = 0,
    average_s: float | None = None,
    t0_C: float = T0_C,
    say: Callable[[str], None] | None = None,
) -> SimulatedBench:
    """Simulate paper A's thermal bench (``say``: told what is simulated, once the truth is
    checked).

    ``parameters`` replaces the paper's thermal coefficients (the effects of the ``thermal``
    preset); ``effects`` switches on further effects, candidates included, e.g.
    ``{"warmup": {"w_warmup": 2.0, "tau_warmup_min": 15.0}}``.
    """
    base = PAPER_A_THERMAL if parameters is None else parameters
    return simulate_bench("thermal", protocol or ThermalProtocol(), base, effects=effects,
                          noise=noise, seed=seed, average_s=average_s, t0_C=t0_C, say=say)


def simulate_magnetic_bench(
    *,
    parameters: Mapping[str, float] | None = None,
    effects: Mapping[str, Mapping[str, float]] | None = None,
    protocol: MagneticProtocol | None = None,
    noise: GyroNoise | None = None,
    seed: int = 0,
    average_s: float | None = None,
    t0_C: float = T0_C,
    say: Callable[[str], None] | None = None,
) -> SimulatedBench:
    """Simulate paper A's Helmholtz-coil bench (default: device 2, test 1, and w0 = 1.197;
    ``say`` as for :func:`simulate_thermal_bench`)."""
    default = {"w0": PAPER_A_THERMAL["w0"], **PAPER_A_DEVICE_2}
    return simulate_bench("magnetic", protocol or MagneticProtocol(),
                          default if parameters is None else parameters, effects=effects,
                          noise=noise, seed=seed, average_s=average_s, t0_C=t0_C, say=say)


def lab_wander(time_s: np.ndarray, lab_C: float, amplitude_C: float, period_h: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """A lab's temperature (degC) wandering sinusoidally about ``lab_C`` and its exact rate
    (degC/h), at ``time_s``: the magnetic and overload benches' thermal background."""
    phase = 2.0 * np.pi * time_s / (3600.0 * period_h)
    return (lab_C + amplitude_C * np.sin(phase),
            amplitude_C * np.cos(phase) * 2.0 * np.pi / period_h)


def preset_parameters(preset: str) -> dict[str, float]:
    """Paper A's default truth for a preset's parameters."""
    values = {**PAPER_A_THERMAL, **PAPER_A_DEVICE_2, **OVERLOAD_SENSITIVITIES}
    names = [p for e in PRESETS[preset] for p in EFFECTS[e].parameter_names]
    return {name: values[name] for name in names}
