"""Paper A's thermal bench written straight to a file, chunk by chunk: logs too long to hold
(a day at 1 kHz is 8.6 x 10^7 rows), simulated with memory that does not grow with them.

The chunks are one log: time from the first sample (not the chunk's), the Gauss-Markov
noise carried across chunk boundaries by its filter state, and one random stream per noise
source (the gyro's white noise, its Gauss-Markov shocks, the thermometer's, the
magnetometer's), each drawn in order, so that the log does not depend on the chunk size.
(The in-memory simulator, :func:`gyroid.simulation.simulate_thermal_bench`, draws its noise
from one stream; a streamed log is the same process, not the same numbers, for a seed.)

The drift is evaluated chunk by chunk, which every effect allows but ``thermal_lag`` (its
lagged temperature needs the whole history); the thermal bench's field is constant, so a
field-change sign (hysteresis) is zero throughout, as in the in-memory simulator.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._log_writer import bench_log_writer
from gyroid.io._logs import BenchLog
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import FIELD_COLUMNS, T0_C, inputs_from_arrays
from gyroid.simulation._bench import PAPER_A_THERMAL, ThermalProtocol
from gyroid.simulation._noise import GM_ADEV_PEAK, GyroNoise
from gyroid.simulation._truth import resolve_truth, truth_comments, truth_record

#: Rows simulated and written per chunk.
CHUNK_ROWS = 1 << 20
#: Effects whose value at a row depends on the whole history before it (not streamable).
HISTORY_EFFECTS = ("thermal_lag",)
#: Rows of the thinned copy kept for a figure (every k-th row; a figure draws fewer still).
SHOWN_ROWS = 100_000


@dataclass(frozen=True)
class StreamedBench:
    """A simulated log written to ``path``: its truth, its length, and every
    ``shown_every``-th row (the log and the true drift) for a figure."""

    path: Path
    truth: dict
    n_rows: int
    shown: BenchLog
    shown_true_drift_deg_h: np.ndarray
    shown_every: int


def thermal_bench_rows(protocol: ThermalProtocol) -> int:
    """Rows of a thermal bench log (``numpy.arange(0, duration, sample)``'s length)."""
    return int(np.ceil(protocol.duration_s / protocol.sample_s))


def stream_thermal_bench(
    path: str | Path,
    *,
    parameters: Mapping[str, float] | None = None,
    effects: Mapping[str, Mapping[str, float]] | None = None,
    protocol: ThermalProtocol | None = None,
    noise: GyroNoise | None = None,
    seed: int = 0,
    t0_C: float = T0_C,
    chunk_rows: int = CHUNK_ROWS,
    say: Callable[[str], None] | None = None,
) -> StreamedBench:
    """Simulate paper A's thermal bench into ``path`` (``.csv``, ``.csv.gz`` or
    ``.parquet``), ``chunk_rows`` rows at a time (arguments as
    :func:`gyroid.simulation.simulate_thermal_bench`; see the module docstring)."""
    protocol = protocol or ThermalProtocol()
    noise = noise or GyroNoise()
    base = dict(PAPER_A_THERMAL if parameters is None else parameters)
    terms, values = resolve_truth(base, effects)
    history = [t for t in terms if t in HISTORY_EFFECTS]
    if history:
        raise GyroidInputError(
            f"{history[0]} needs the whole temperature history, so a log written chunk by "
            "chunk (gyroid simulate writes so above 2 x 10^7 rows) cannot carry it: simulate "
            "fewer rows (--hours, --rate-hz) or leave the effect out")
    n = thermal_bench_rows(protocol)
    if say is not None:
        say(f"simulating the thermal bench ({n} rows, written in chunks of {chunk_rows}) ...")
    model = DriftModel(terms=terms)
    params = {name: jnp.asarray(values[name]) for name in model.parameter_names}
    white, shocks, thermometer, magnetometer = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(4))
    gm = _GaussMarkov(noise, protocol.sample_s, shocks)
    lab_field = np.asarray(protocol.lab_field_uT, dtype=float)
    every = max(1, n // SHOWN_ROWS)
    shown: dict[str, list[np.ndarray]] = {}
    names = ["time_s", "drift_deg_h", "temperature_C", *FIELD_COLUMNS]
    truth = truth_record("thermal", model, values, noise, protocol.sample_s, asdict(protocol),
                         None, seed, t0_C)
    with bench_log_writer(path, names, truth_comments(truth)) as append:
        for start in range(0, n, chunk_rows):
            index = np.arange(start, min(start + chunk_rows, n))
            time_s = index * protocol.sample_s
            temperature, rate = protocol.temperature(time_s)
            field = np.broadcast_to(lab_field, (index.size, 3))
            inputs = inputs_from_arrays(time_s, temperature, rate, field, None, t0_C=t0_C,
                                        origin_s=0.0)
            true_drift = np.asarray(model(params, inputs))
            gyro = (white.standard_normal(index.size) * noise.white_sd_deg_h(protocol.sample_s)
                    + gm.next(index.size))
            chunk = {"time_s": time_s, "drift_deg_h": true_drift + gyro,
                     "temperature_C": temperature
                     + thermometer.standard_normal(index.size) * noise.temperature_noise_C}
            measured = field + magnetometer.standard_normal((index.size, 3)) * noise.field_noise_uT
            chunk |= {name: measured[:, k] for k, name in enumerate(FIELD_COLUMNS)}
            append(chunk)
            keep = (index % every) == 0
            for name, column in (chunk | {"true": true_drift}).items():
                shown.setdefault(name, []).append(column[keep])
    columns = {name: np.concatenate(parts) for name, parts in shown.items()}
    true_shown = columns.pop("true")
    log = BenchLog(columns=columns, source=str(path), comments=truth_comments(truth))
    return StreamedBench(Path(path), truth, n, log, true_shown, every)


class _GaussMarkov:
    """The gyro's stationary first-order Gauss-Markov noise (sd ``bias_instability /
    0.6174``), continued from chunk to chunk: ``x[k] = phi x[k-1] + sqrt(1 - phi^2) sd e[k]``,
    started from its stationary distribution."""

    def __init__(self, noise: GyroNoise, sample_s: float, rng: np.random.Generator):
        self.sd = noise.bias_instability_deg_h / GM_ADEV_PEAK
        self.phi = float(np.exp(-sample_s / noise.correlation_time_s))
        self.rng = rng
        self.state: np.ndarray | None = None  # the filter's state after the last sample

    def next(self, size: int) -> np.ndarray:
        if self.sd == 0.0 or size == 0:
            return np.zeros(size)
        from scipy.signal import lfilter  # here: importing scipy.signal is slow at start-up

        draws = self.rng.standard_normal(size)  # one draw per sample, whatever the chunks
        shocks = draws * (self.sd * np.sqrt(1.0 - self.phi**2))
        if self.state is None:  # the first sample: from the stationary distribution
            shocks[0] = draws[0] * self.sd
            self.state = np.zeros(1)
        out, self.state = lfilter([1.0], [1.0, -self.phi], shocks, zi=self.state)
        return out
