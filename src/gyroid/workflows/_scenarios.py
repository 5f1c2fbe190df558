"""Flight scenarios for propagating a fitted gyro through paper B's loop: paper B's worked
example and its variants as presets, or a user's JSON/TOML file of the same fields."""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path

from gyroid.errors import GyroidInputError
from gyroid.models import _paper_b as pb
from gyroid.models._inputs import T0_C


@dataclass(frozen=True)
class Scenario:
    """A flight scenario. Defaults: paper B's worked example (roll 900 deg/s, dt 5 s,
    uncompensated rate 300 deg/s, MEMS SF error 280 ppm, encoder 0.33 deg), with the fitted
    FOG as the SINS roll gyro in a flight whose temperature rises 5 degC in 120 s."""

    name: str = "paper_b_worked"
    roll_rate_deg_s: float = 900.0
    period_s: float = 5.0
    duration_s: float = 120.0
    sample_s: float = 0.05
    sins_sf_error: float = pb.SINS_SF_ERROR  # D1, what the loop corrects
    uncompensated_deg_s: float = 300.0
    uncompensated_sd_deg_s: float = 5.0
    mems_sf_error: float = pb.MEMS_SF_ERROR
    mems_sf_error_sd: float = 28e-6
    mems_bias_deg_h: float = 12.2
    mems_bias_sd_deg_h: float = 1.2
    encoder_deg: float = pb.ENCODER_ERROR_DEG
    encoder_phase: str = "uniform"  # or a fixed phase in rad, as a number in a string
    fitted_gyro_role: str = "sins"  # "sins" (the roll gyro) or "stabiliser" (the GS gyro)
    period_index: int = -1  # which correction period's dK: -1 draws it uniformly
    temperature_start_C: float = T0_C
    temperature_rise_C: float = 5.0
    earth_field_uT: tuple[float, float] = (20.0, 45.0)  # along the roll axis, across it

    def as_dict(self) -> dict:
        return asdict(self)


SCENARIOS = {
    "paper_b_worked": Scenario(),
    "paper_b_worked_stabiliser": Scenario(name="paper_b_worked_stabiliser",
                                          fitted_gyro_role="stabiliser"),
    "ideal_stabiliser": Scenario(name="ideal_stabiliser", uncompensated_deg_s=0.0,
                                 uncompensated_sd_deg_s=0.0),
    "table2": Scenario(name="table2", roll_rate_deg_s=3600.0, uncompensated_deg_s=280.0,
                       uncompensated_sd_deg_s=5.0),
}


def load_scenario(spec: str | None) -> Scenario:
    """A preset name, or a JSON/TOML file of Scenario fields (unknown keys are refused)."""
    if spec is None:
        return SCENARIOS["paper_b_worked"]
    if spec in SCENARIOS:
        return SCENARIOS[spec]
    path = Path(spec)
    if not path.is_file():
        raise GyroidInputError(f"--scenario {spec!r} is neither a preset "
                               f"({', '.join(SCENARIOS)}) nor a file")
    try:
        text = path.read_text(encoding="utf-8")
        data = tomllib.loads(text) if path.suffix == ".toml" else json.loads(text)
    except (UnicodeDecodeError, json.JSONDecodeError, tomllib.TOMLDecodeError) as error:
        raise GyroidInputError(f"{path.name}: not valid {path.suffix[1:]}: {error}") from None
    if not isinstance(data, dict):
        raise GyroidInputError(f"{path.name}: a scenario file holds one table (JSON object) "
                               "of scenario fields")
    known = {f.name for f in fields(Scenario)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise GyroidInputError(f"{path.name}: unknown scenario key {unknown[0]!r}; known: "
                               f"{', '.join(sorted(known))}")
    values = {"name": path.stem} | {key: _checked(path.name, key, value)
                                    for key, value in data.items()}
    scenario = replace(SCENARIOS["paper_b_worked"], **values)
    if scenario.period_s > scenario.duration_s or scenario.sample_s > scenario.period_s:
        raise GyroidInputError(f"{path.name}: need sample_s <= period_s <= duration_s (here "
                               f"{scenario.sample_s:g}, {scenario.period_s:g}, "
                               f"{scenario.duration_s:g} s)")
    return scenario


#: Fields that must be positive, and fields that must not be negative.
_POSITIVE = ("period_s", "duration_s", "sample_s")
_NOT_NEGATIVE = ("uncompensated_sd_deg_s", "mems_sf_error_sd", "mems_bias_sd_deg_h",
                 "encoder_deg")


def _checked(file: str, key: str, value):
    """A scenario field's value of the right kind (one message naming the key if not)."""
    default = getattr(SCENARIOS["paper_b_worked"], key)

    def refuse(what: str):
        return GyroidInputError(f"{file}: scenario key {key!r} = {value!r}: {what}")

    if key == "name":
        if not isinstance(value, str) or not value.strip():
            raise refuse("give a name (text)")
        return value
    if key == "fitted_gyro_role":
        if value not in ("sins", "stabiliser"):
            raise refuse("use 'sins' or 'stabiliser'")
        return value
    if key == "encoder_phase":
        if value != "uniform" and not _number(value, text_ok=True):
            raise refuse("use 'uniform' or a phase in rad")
        return str(value)
    if key == "earth_field_uT":
        if not isinstance(value, list | tuple) or len(value) != 2 or not all(
                _number(v) for v in value):
            raise refuse("give two numbers, uT (along the roll axis, across it)")
        return (float(value[0]), float(value[1]))
    if key == "period_index":
        if not isinstance(value, int) or isinstance(value, bool):
            raise refuse("give a whole number (-1: drawn uniformly)")
        return value
    if not _number(value):
        raise refuse(f"give a number (as {default!r} is), not {type(value).__name__}")
    value = float(value)
    if key in _POSITIVE and value <= 0:
        raise refuse("must be positive")
    if key in _NOT_NEGATIVE and value < 0:
        raise refuse("must not be negative")
    return value


def _number(value, text_ok: bool = False) -> bool:
    if isinstance(value, bool):
        return False
    if isinstance(value, str) and text_ok:
        try:
            value = float(value)
        except ValueError:
            return False
    return isinstance(value, int | float) and math.isfinite(value)
