"""A gyro datasheet (docs/formats.md section 6): a TOML file whose ``[gyro]`` table gives the
noise terms as strings with units, read into IEEE Std 952's datasheet units.

=====================  ==============================================  ====================
key                    units accepted                                  read as
=====================  ==============================================  ====================
``arw`` or             deg/sqrt(h), deg/h/sqrt(Hz), deg/s/sqrt(Hz),    N, deg/sqrt(h)
``noise_density``      rad/s/sqrt(Hz), mdps/sqrt(Hz), deg/sqrt(s)
``bias_instability``   deg/h, deg/s, mdps, rad/s                       B, deg/h
``rate_random_walk``   deg/h/sqrt(h), deg/s/sqrt(s), deg/s^2/sqrt(Hz),  K, deg/h/sqrt(h)
                       rad/s^2/sqrt(Hz)
``rate``               Hz                                              the IMU's output rate
=====================  ==============================================  ====================

The factors, from the continuous densities: ``1 deg/sqrt(h) = 60 deg/h/sqrt(Hz)`` (an
hour is 3600 s), so ``N = PSD^1/2 [deg/s/sqrt(Hz)] * 3600 / 60``; ``1 deg/h/sqrt(h) =
1 / 216000 deg/s/sqrt(s)``. A spectral density per root hertz and a density per root
second are the same quantity (``1/sqrt(Hz) = sqrt(s)``).
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from gyroid.errors import GyroidInputError

if TYPE_CHECKING:
    from gyroid.models._priors import Prior

DEG = 180.0 / math.pi
#: Per key: the term it gives and, per accepted unit (spelled without spaces, lower case),
#: the factor to the term's datasheet unit.
UNITS: dict[str, tuple[str, str, dict[str, float]]] = {
    "arw": ("N", "deg/sqrt(h)", {
        "deg/sqrt(h)": 1.0, "deg/h/sqrt(hz)": 1.0 / 60.0, "deg/s/sqrt(hz)": 60.0,
        "rad/s/sqrt(hz)": DEG * 60.0, "mdps/sqrt(hz)": 0.06, "deg/sqrt(s)": 60.0}),
    "bias_instability": ("B", "deg/h", {
        "deg/h": 1.0, "deg/s": 3600.0, "mdps": 3.6, "rad/s": DEG * 3600.0}),
    "rate_random_walk": ("K", "deg/h/sqrt(h)", {
        "deg/h/sqrt(h)": 1.0, "deg/s/sqrt(s)": 216000.0, "deg/s^2/sqrt(hz)": 216000.0,
        "rad/s^2/sqrt(hz)": DEG * 216000.0}),
}
UNITS["noise_density"] = UNITS["arw"]
#: Other spellings of the same units: a regular expression and its replacement, in order.
_SPELLINGS = ((r"°|degrees?", "deg"), (r"√\(?([a-z]+)\)?", r"sqrt(\1)"),
              (r"(?<!sq)rt\(", "sqrt("), (r"\bhr\b|hours?", "h"), (r"\bsec\b", "s"))


@dataclass(frozen=True)
class DatasheetTerm:
    """One term a datasheet gives: its IEEE name, the key and string it came from, and its
    value in the term's datasheet unit."""

    name: str
    key: str
    given: str
    value: float
    unit: str


@dataclass(frozen=True)
class Datasheet:
    """A datasheet's gyro terms (by IEEE name), its rate (Hz, or None) and where it came
    from."""

    terms: dict[str, DatasheetTerm]
    rate_hz: float | None
    source: str

    def to_json(self) -> dict:
        return {"source": self.source, "rate_hz": self.rate_hz,
                "terms": {n: {"key": t.key, "given": t.given, "value": t.value,
                              "unit": t.unit} for n, t in self.terms.items()}}


def _unit_key(text: str) -> str:
    key = text.strip().lower().replace(" ", "")
    for pattern, spelling in _SPELLINGS:
        key = re.sub(pattern, spelling, key)
    return key


def parse_quantity(key: str, text: object) -> DatasheetTerm:
    """``"0.011 deg/s/sqrt(Hz)"`` under ``key`` as its term in datasheet units; one error
    naming the key, the string and every unit accepted for it."""
    name, unit, factors = UNITS[key]
    accepted = ", ".join(factors)
    match = re.fullmatch(r"\s*([-+0-9.eE]+)\s*(.+)", str(text))
    if not isinstance(text, str) or match is None:
        raise GyroidInputError(f"datasheet [gyro] {key} = {text!r}: give a number and a unit "
                               f"as a string, e.g. \"0.5 {unit}\" (units: {accepted})")
    try:
        number = float(match.group(1))
    except ValueError:
        raise GyroidInputError(f"datasheet [gyro] {key} = {text!r}: {match.group(1)!r} is not "
                               "a number") from None
    factor = factors.get(_unit_key(match.group(2)))
    if factor is None:
        raise GyroidInputError(f"datasheet [gyro] {key} = {text!r}: unit {match.group(2)!r} "
                               f"is not one gyroid reads for {key} ({accepted})")
    if not number > 0:
        raise GyroidInputError(f"datasheet [gyro] {key} = {text!r}: must be positive")
    return DatasheetTerm(name, key, str(text), number * factor, unit)


def read_datasheet(path: str | Path) -> Datasheet:
    """The ``[gyro]`` table of a datasheet TOML file (module docstring)."""
    path = Path(path)
    try:
        record = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise GyroidInputError(f"{path}: no such datasheet file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise GyroidInputError(f"{path}: not a TOML file ({error})") from None
    gyro = record.get("gyro")
    if not isinstance(gyro, dict):
        raise GyroidInputError(f"{path}: no [gyro] table; give arw (or noise_density), "
                               "bias_instability and optionally rate_random_walk there")
    unknown = sorted(set(gyro) - set(UNITS) - {"rate"})
    if unknown:
        raise GyroidInputError(f"{path}: [gyro] {unknown[0]} is not a key gyroid reads "
                               f"({', '.join([*UNITS, 'rate'])})")
    if "arw" in gyro and "noise_density" in gyro:
        raise GyroidInputError(f"{path}: [gyro] gives both arw and noise_density; give one")
    terms = {}
    for key in UNITS:
        if key in gyro:
            term = parse_quantity(key, gyro[key])
            terms[term.name] = term
    if not terms:
        raise GyroidInputError(f"{path}: [gyro] gives no noise term")
    rate = None
    if "rate" in gyro:
        match = re.fullmatch(r"\s*([0-9.eE+]+)\s*hz\s*", str(gyro["rate"]).lower())
        if match is None or not float(match.group(1)) > 0:
            raise GyroidInputError(f"{path}: [gyro] rate = {gyro['rate']!r}: give it as "
                                   "\"200 Hz\"")
        rate = float(match.group(1))
    return Datasheet(terms, rate, str(path))


#: A datasheet's typical value as a prior: log-normal about it with this log-sd, a unit
#: within a factor of 2 of the typical value at one sd (4 at two): datasheets state typical
#: values, and units of one type differ by tens of percent in N and by up to a few times in
#: B and K. Narrower than 2, so the fit's allowed-noise check keeps it (a measured prior,
#: :mod:`gyroid.bench._allowed_noise`).
DATASHEET_LOG_SD = math.log(2.0)
#: The IEEE 952 levels of the bench fit's noise model that a datasheet's terms set.
LEVELS = {"N": "N_deg_sqrt_h", "B": "B_deg_h", "K": "K_deg_h_sqrt_h"}


def datasheet_priors(sheet: Datasheet) -> dict[str, Prior]:
    """The bench fit's IEEE 952 noise priors from a datasheet (``gyroid fit --noise
    FILE.toml``): each term it gives, log-normal about its typical value with log-sd
    :data:`DATASHEET_LOG_SD`, in the datasheet's units (deg/sqrt(h), deg/h,
    deg/h/sqrt(h): the levels' own); its bias instability read as IEEE's B, as
    ``gyroid noise --datasheet`` compares it. A level the datasheet omits keeps its
    default prior."""
    from gyroid.models._priors import LogNormal  # JAX: not for `gyroid datasheet`

    return {LEVELS[name]: LogNormal(term.value, DATASHEET_LOG_SD)
            for name, term in sheet.terms.items()}
