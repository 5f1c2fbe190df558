"""A datasheet as an estimator's noise file, with the derivation shown
(``gyroid datasheet``), and a measured noise fit judged against its datasheet
(``gyroid noise --datasheet``): docs/formats.md section 6.

Kalibr, OpenVINS and VINS-style estimators want continuous-time densities: the white
noise's ``gyroscope_noise_density = N (pi/180) / 60`` rad/s/sqrt(Hz) (N in deg/sqrt(h)) and
the bias random walk's ``gyroscope_random_walk = K (pi/180) / 3600 / 60`` rad/s^2/sqrt(Hz)
(K in deg/h/sqrt(h)); their discrete-time sds at the IMU's rate ``r`` are the density times
``sqrt(r)`` (a sample's white noise, rad/s) and the walk over ``sqrt(r)`` (the bias's step
per sample, rad/s). Bias instability has no term in their models. A datasheet without a
rate random walk gets the walk whose Allan deviation reaches the flicker floor
``0.664 B`` at the horizon ``T`` (``K = 0.664 B 60 sqrt(3 / T)``: from ``T`` on it
over-bounds the flicker, below ``T`` it lies under it), said so, in place of a fixed
10-20x inflation of whatever the Allan plot gave.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gyroid.errors import GyroidInputError
from gyroid.io._datasheet import Datasheet
from gyroid.workflows._noise_export import (
    ARW_TO_SI,
    FILE_NAMES,
    HORIZON_S,
    NOISE_TARGETS,
    RRW_TO_SI,
    NoiseExport,
    flicker_walk,
)

#: ``gyroid datasheet --to``: an estimator's file, or the conversion alone.
DATASHEET_TARGETS = (*NOISE_TARGETS, "json")


@dataclass(frozen=True)
class DatasheetExport:
    """A datasheet converted for ``target``: the estimator's densities (SI), where the walk
    came from, every step of the derivation, and the estimator's file (None for json)."""

    target: str
    sheet: Datasheet
    noise_density: float
    random_walk: float
    walk_from: str
    derivation: tuple[str, ...]
    file: NoiseExport | None

    @property
    def trustworthy(self) -> bool:
        return True

    def to_json(self) -> dict:
        """``datasheet.json``."""
        return {"target": self.target, "datasheet": self.sheet.to_json(),
                "gyroscope_noise_density": self.noise_density,
                "gyroscope_random_walk": self.random_walk, "walk_from": self.walk_from,
                "units": {"gyroscope_noise_density": "rad/s/sqrt(Hz)",
                          "gyroscope_random_walk": "rad/s^2/sqrt(Hz)"},
                "derivation": list(self.derivation)}


def convert_datasheet(sheet: Datasheet, target: str, *, rate_hz: float | None = None,
                      horizon_s: float = HORIZON_S, topic: str = "/imu0") -> DatasheetExport:
    """The datasheet's terms as ``target``'s parameters (module docstring). ``rate_hz``: the
    IMU's rate (default: the datasheet's ``rate``), for the discrete-time sds and the
    file's ``update_rate``."""
    if target not in DATASHEET_TARGETS:
        raise GyroidInputError(f"--to {target!r}: use one of {', '.join(DATASHEET_TARGETS)}")
    if "N" not in sheet.terms:
        raise GyroidInputError(f"{sheet.source}: [gyro] gives no arw or noise_density; an "
                               "estimator's white-noise density comes from it")
    rate = rate_hz if rate_hz is not None else sheet.rate_hz
    lines = [f"{t.key} = \"{t.given}\" -> {t.name} = {t.value:.6g} {t.unit}"
             for t in sheet.terms.values()]
    n = sheet.terms["N"].value
    density = n * ARW_TO_SI
    lines.append(f"gyroscope_noise_density = N (pi/180) / 60 = {density:.6e} rad/s/sqrt(Hz) "
                 "(continuous: what Kalibr, OpenVINS and VINS read)")
    if "K" in sheet.terms:
        k, walk_from = sheet.terms["K"].value, "the datasheet's rate_random_walk"
    elif "B" in sheet.terms:
        b = sheet.terms["B"].value
        k = flicker_walk(b, horizon_s)
        walk_from = (f"the walk whose Allan deviation reaches B's flicker floor at "
                     f"{horizon_s:g} s (the datasheet gives no rate_random_walk)")
        lines.append(f"no rate_random_walk: K = 0.664 B 60 sqrt(3 / T) = {k:.6g} "
                     f"deg/h/sqrt(h) with T = {horizon_s:g} s (over-bounds the flicker "
                     "from T on, under-states it below)")
    else:
        raise GyroidInputError(f"{sheet.source}: [gyro] gives neither rate_random_walk nor "
                               "bias_instability; an estimator's bias random walk needs one")
    walk = k * RRW_TO_SI
    lines.append(f"gyroscope_random_walk = K (pi/180) / 3600 / 60 = {walk:.6e} "
                 "rad/s^2/sqrt(Hz) (continuous)")
    if rate is not None:
        lines.append(f"at {rate:g} Hz, discrete: white sd = density sqrt(rate) = "
                     f"{density * math.sqrt(rate):.6e} rad/s per sample; bias step = walk / "
                     f"sqrt(rate) = {walk / math.sqrt(rate):.6e} rad/s per sample")
    if "B" in sheet.terms:
        lines.append(f"B = {sheet.terms['B'].value:.6g} deg/h: Kalibr's and OpenVINS's models "
                     "have no bias-instability term")
    file = None
    if target in NOISE_TARGETS:
        comments = (f"from the datasheet {sheet.source}; derivation in datasheet.json",
                    f"gyroscope_random_walk: {walk_from}",
                    "accelerometer values: fill in from the accelerometer's datasheet")
        file = NoiseExport(target, FILE_NAMES[target], {}, comments, density, walk, rate,
                           topic)
    return DatasheetExport(target, sheet, density, walk, walk_from, tuple(lines), file)


def spec_verdicts(terms: dict[str, dict], sheet: Datasheet) -> dict[str, dict]:
    """Per term the datasheet gives, the measured term (a noise fit's ``term_summaries``:
    its 90 % interval, or ``[0, bound]`` when unresolved) against it: ``within`` when the
    interval holds the datasheet's value, ``above`` or ``below`` when it lies wholly above
    or below."""
    out = {}
    for name, given in sheet.terms.items():
        entry = terms.get(name)
        if entry is None:
            continue
        if entry["resolved"]:
            lo, hi = entry["ci90"]
        elif entry.get("upper_bound_95") is not None:
            lo, hi = 0.0, entry["upper_bound_95"]
        else:
            continue
        verdict = "within" if lo <= given.value <= hi else ("above" if lo > given.value
                                                              else "below")
        out[name] = {"datasheet": given.value, "unit": given.unit, "measured": [lo, hi],
                     "verdict": verdict}
    return out
