"""What ``gyroid propagate`` does: read a fit's folder, push its posterior through paper B's
correction loop under a scenario, write the result."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from gyroid.errors import GyroidInputError
from gyroid.io._fitted import FittedDrift
from gyroid.io._outputs import output_dir
from gyroid.reports._write import write
from gyroid.workflows._propagate import Propagation, propagate
from gyroid.workflows._scenarios import load_scenario


def propagate_dir(fit_dir: Path, out: Path, scenario: str | None = None, *, draws: int = 2000,
                  seed: int = 0, say: Callable[[str], None] = lambda _m: None) -> Propagation:
    """Propagate the fit in ``fit_dir`` through ``scenario`` (a preset's name, a JSON or
    TOML file, or None for paper_b_worked) with ``draws`` Monte-Carlo draws; write
    ``propagate.json`` and the figures to ``out``. ``say`` receives progress lines."""
    if draws < 10:
        raise GyroidInputError("--draws must be at least 10")
    fitted = FittedDrift.from_dir(fit_dir)
    chosen = load_scenario(scenario)
    say(f"propagating {fit_dir} through scenario {chosen.name} ...")
    result = propagate(fitted, chosen, draws=draws, seed=seed, progress=say)
    with output_dir(out) as stage:
        write(stage, result)
    return result
