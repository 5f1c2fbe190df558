"""What ``gyroid roll simulate`` and ``gyroid roll fit`` do: simulate a flight into a folder;
read a roll log, fit paper B's loop and write the result."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from gyroid.inference._emcee import Emcee
from gyroid.inference._importance import Importance
from gyroid.io._outputs import json_text, output_dir
from gyroid.io._roll_log import load_roll_log
from gyroid.io._units import ColumnMap
from gyroid.reports._write import write
from gyroid.roll._fit import fit_roll_log
from gyroid.roll._result import RollFit
from gyroid.simulation._flight import FlightProfile, roll_log_text, simulate_flight


def simulate_roll_dir(out: Path, profile: FlightProfile, params: Mapping[str, float], *,
                      seed: int = 0) -> str:
    """Simulate a flight with known truth into ``out`` (roll.csv, truth.json); returns what
    was written, one line."""
    sim = simulate_flight(params=dict(params), profile=profile, seed=seed)
    with output_dir(out) as stage:
        (stage / "roll.csv").write_text(roll_log_text(
            sim.columns, [f"gyroid simulated flight, seed {seed}"]))
        (stage / "truth.json").write_text(json_text(sim.truth))
    return (f"wrote {out / 'roll.csv'} ({sim.columns['time_s'].size} rows) and "
            f"{out / 'truth.json'}")


def roll_fit_file(path: Path, out: Path, *, maps: tuple[ColumnMap, ...] = (), seed: int = 0,
                  progress: bool = True, say: Callable[[str], None] = lambda _m: None
                  ) -> RollFit:
    """Fit paper B's loop to the roll log at ``path`` and write ``roll_fit.json``,
    ``posterior.nc`` and the figures to ``out``. ``say`` receives the log's notes and
    progress lines; ``progress`` shows emcee's bar where it walks (importance sampling,
    the default, takes seconds)."""
    log = load_roll_log(path, maps)
    for note in log.notes:
        say(f"note: {note}")
    say(f"fitting the roll loop to {path} ({log.n} rows) ...")
    result = fit_roll_log(log, seed=seed,
                          sampler=Importance(fallback=Emcee(progress=progress)))
    with output_dir(out) as stage:
        write(stage, result)
    return result
