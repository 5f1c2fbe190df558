"""What ``gyroid simulate`` does: simulate paper A's thermal or magnetic bench (one run, a
run too long to hold written chunk by chunk, or a lot of runs) and write the log, its
truth and its figure into a folder, atomically."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

from gyroid.errors import GyroidInputError
from gyroid.io import _stream
from gyroid.io._log_writer import write_bench_log
from gyroid.io._outputs import json_text, output_dir
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.plotting import magnetic_sweep, overload_run, save, thermal_run
from gyroid.simulation._bench import (
    MagneticProtocol,
    ThermalProtocol,
    simulate_magnetic_bench,
    simulate_thermal_bench,
)
from gyroid.simulation._lot import simulate_lot
from gyroid.simulation._noise import GyroNoise
from gyroid.simulation._overload import OverloadProtocol, simulate_overload_bench
from gyroid.simulation._stream import stream_thermal_bench, thermal_bench_rows


@dataclass(frozen=True)
class SimulateOptions:
    """What to simulate: the bench's coefficients (``parameters``, its preset's with the
    user's changes), effects beyond the preset's, the noise, length (h) and rate (Hz) when
    not the protocol's, samples averaged over ``average_s`` (s), the log's format, and for
    ``runs > 1`` a lot whose coefficients spread by ``spread`` (relative)."""

    parameters: dict[str, float]
    effects: dict[str, dict[str, float]]
    noise: GyroNoise
    seed: int = 0
    hours: float | None = None
    rate_hz: float | None = None
    average_s: float | None = None
    log_format: str = "csv"
    runs: int = 1
    spread: float = 0.2
    #: The overload bench's dwell directions (None: the six-position tumble).
    orientations: tuple[str, ...] | None = None


class _RunOptions(TypedDict):
    """What every bench simulator takes beside its protocol."""

    parameters: dict[str, float]
    effects: dict[str, dict[str, float]]
    noise: GyroNoise
    seed: int
    average_s: float | None
    say: Callable[[str], None]


def simulate_to_dir(bench: str, out: Path, options: SimulateOptions,
                    say: Callable[[str], None] = lambda _m: None) -> str:
    """Simulate ``bench`` ("thermal", "magnetic" or "overload") into the folder ``out``;
    returns what was written, one line. ``say`` receives progress lines."""
    o = options
    if o.noise.arw_deg_rt_h < 0 or o.noise.bias_instability_deg_h < 0 \
            or o.noise.correlation_time_s <= 0:
        raise GyroidInputError("noise levels must be >= 0 and the correlation time > 0")
    if (o.hours is not None and o.hours <= 0) or (o.rate_hz is not None and o.rate_hz <= 0):
        raise GyroidInputError("--hours and --rate-hz must be positive")
    if o.runs < 1:
        raise GyroidInputError("--runs must be at least 1")
    if bench == "overload" and o.runs > 1:
        raise GyroidInputError("--runs is for the thermal and magnetic benches")
    if o.runs > 1:
        if o.effects:
            raise GyroidInputError("--effect is for single runs; a lot (--runs) varies the "
                                   "preset's coefficients only")
        return _simulate_lot(bench, out, o)
    if o.orientations is not None and bench != "overload":
        raise GyroidInputError("--orientations is for the overload bench")
    log_name = f"bench.{o.log_format}"
    run = _RunOptions(parameters=o.parameters, effects=o.effects, noise=o.noise, seed=o.seed,
                      average_s=o.average_s, say=say)
    if bench == "thermal":
        thermal = ThermalProtocol().stretched(o.hours, o.rate_hz)
        rows = thermal_bench_rows(thermal)
        if rows > _stream.STREAM_ROWS:  # the module's constant read here (a test lowers it)
            if o.average_s:
                raise GyroidInputError(
                    f"--average on a log of {rows} rows: its window means are those of a "
                    "slower log; simulate at a lower --rate-hz with --average")
            return _simulate_streamed(out, log_name, thermal, o, say)
        sim = simulate_thermal_bench(**run, protocol=thermal)
        fig = _thermal_figure(sim.log, None if o.average_s else sim.true_drift_deg_h, thermal)
    elif bench == "magnetic":
        sim = simulate_magnetic_bench(**run,
                                      protocol=MagneticProtocol().stretched(o.hours, o.rate_hz))
        fig = magnetic_sweep(sim.log)
    else:
        tumble = (OverloadProtocol(orientations=o.orientations) if o.orientations
                  else OverloadProtocol())
        sim = simulate_overload_bench(**run, protocol=tumble.stretched(o.hours, o.rate_hz))
        fig = overload_run(sim.log)
    with output_dir(out) as stage:
        write_bench_log(stage / log_name, sim.log.columns, sim.log.comments)
        (stage / "truth.json").write_text(json_text(sim.truth))
        save(fig, stage / "bench.png")
    return f"wrote {out / log_name} ({sim.log.n} rows) and {out / 'truth.json'}"


def _thermal_figure(log, true_drift, protocol: ThermalProtocol, thinned_by: int = 1):
    """A simulated thermal run's figure, dT/dt estimated over paper A's window scaled with
    the protocol's transitions (the default suits its hour-long ones)."""
    window = RATE_WINDOW_S * protocol.transition_min / ThermalProtocol().transition_min
    return thermal_run(log, log.inputs(rate_window_s=window).rate_C_h, true_drift,
                       rate_window_s=window, thinned_by=thinned_by)


def _simulate_streamed(out: Path, log_name: str, protocol: ThermalProtocol,
                       o: SimulateOptions, say: Callable[[str], None]) -> str:
    """A thermal log too long to hold, written chunk by chunk (its figure from every k-th
    row)."""
    with output_dir(out) as stage:
        sim = stream_thermal_bench(stage / log_name, protocol=protocol, say=say,
                                   parameters=o.parameters, effects=o.effects, noise=o.noise,
                                   seed=o.seed)
        (stage / "truth.json").write_text(json_text(sim.truth))
        save(_thermal_figure(sim.shown, sim.shown_true_drift_deg_h, protocol,
                             thinned_by=sim.shown_every), stage / "bench.png")
    return (f"wrote {out / log_name} ({sim.n_rows} rows, written in chunks) and "
            f"{out / 'truth.json'}")


def _simulate_lot(bench: str, out: Path, o: SimulateOptions) -> str:
    """A simulated lot: OUT/run_NN/bench.csv and truth.json, and OUT/lot.json."""
    lot = simulate_lot(bench, o.runs, spread=o.spread, mean=o.parameters, noise=o.noise,
                       seed=o.seed, hours=o.hours, rate_hz=o.rate_hz, average_s=o.average_s)
    with output_dir(out) as stage:
        for label, sim in zip(lot.labels, lot.runs, strict=True):
            (stage / label).mkdir()
            write_bench_log(stage / label / "bench.csv", sim.log.columns, sim.log.comments)
            (stage / label / "truth.json").write_text(json_text(sim.truth))
        (stage / "lot.json").write_text(json_text(lot.truth()))
    return (f"wrote {o.runs} runs to {out}/run_*/bench.csv and the lot's truth to "
            f"{out / 'lot.json'}")
