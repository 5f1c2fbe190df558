"""A noise fit as a visual-inertial estimator's IMU noise file (docs/formats.md section 5).

Kalibr, OpenVINS and VINS-style estimators model each gyro axis as white noise plus a bias
random walk, in continuous time:

* ``gyroscope_noise_density`` [rad/s/sqrt(Hz)] is the angle random walk:
  ``N [deg/sqrt(h)] * (pi/180) / 60``;
* ``gyroscope_random_walk`` [rad/s^2/sqrt(Hz)] is the rate random walk:
  ``K [deg/h/sqrt(h)] * (pi/180) / 3600 / 60``.

One value serves every axis: the largest over the axes (an estimator that under-states an
axis's noise is over-confident). A walk the log is too short to resolve is written as its
95 % upper bound, and said so (zero would tell the estimator the bias never moves). The
terms the estimators cannot represent (bias instability, quantisation, rate ramp) are left
out, and what leaving them out costs is stated: the largest factor by which the white +
random-walk model under-states the fitted model's Allan deviation over the averaging times
the log covers. gyroid fits gyros only: the accelerometer keys are written as comments to
be filled in from an accelerometer characterisation, so an estimator refuses the file until
they are, rather than running on invented values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._fitted import FittedNoise

#: deg/sqrt(h) -> rad/s/sqrt(Hz), and deg/h/sqrt(h) -> rad/s^2/sqrt(Hz).
ARW_TO_SI = math.pi / 180.0 / 60.0
RRW_TO_SI = math.pi / 180.0 / 3600.0 / 60.0
NOISE_TARGETS = ("kalibr", "openvins")
FILE_NAMES = {"kalibr": "imu.yaml", "openvins": "kalibr_imu_chain.yaml"}
LEFT_OUT = ("B", "Q", "R")
#: The flicker floor per unit bias instability (IEEE Std 952: ``2 ln 2 / pi`` under a root).
FLOOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: The horizon at which a walk standing in for flicker reaches its floor, s.
HORIZON_S = 100.0


def flicker_walk(b_deg_h: float, horizon_s: float = HORIZON_S) -> float:
    """The rate random walk (deg/h/sqrt(h)) whose Allan deviation ``K/60 sqrt(tau/3)``
    reaches the flicker floor ``0.664 B`` at ``horizon_s``: from there on it over-bounds the
    flicker, below it lies under it."""
    return FLOOR * b_deg_h * 60.0 * math.sqrt(3.0 / horizon_s)


@dataclass(frozen=True)
class AxisNoise:
    """One axis's white and random-walk levels in the estimators' units, how each was chosen
    (``posterior mean`` or ``95 % upper bound``), and the factor by which the white +
    random-walk model under-states the fitted Allan deviation at worst (at ``worst_tau_s``)."""

    axis: str | None
    noise_density: float
    random_walk: float
    density_from: str
    walk_from: str
    understated_by: float
    worst_tau_s: float
    left_out: dict[str, float]
    trustworthy: bool
    #: The walk (rad/s^2/sqrt(Hz)) that over-bounds the fitted flicker from HORIZON_S on, at
    #: B's 95 % upper end (interval or bound); None without a B.
    flicker_walk: float | None = None


def axis_noise(axis: str | None, fitted: FittedNoise) -> AxisNoise:
    """One axis's levels for the estimators (module docstring)."""
    n_deg, n_from = _level(fitted.terms, "N", axis)
    k_deg, k_from = _level(fitted.terms, "K", axis)
    tau_h = fitted.tau_s / 3600.0
    kept = np.sqrt(n_deg ** 2 / tau_h + k_deg ** 2 * tau_h / 3.0)
    ratio = fitted.model_adev_deg_h / np.maximum(kept, np.finfo(float).tiny)
    worst = int(np.argmax(ratio))
    left_out = {name: float(fitted.terms[name]["mean"]) for name in LEFT_OUT
                if fitted.terms.get(name, {}).get("resolved")}
    b = fitted.terms.get("B", {})
    b_top = b["ci90"][1] if b.get("resolved") else b.get("upper_bound_95")
    walk = None if b_top is None else flicker_walk(float(b_top)) * RRW_TO_SI
    return AxisNoise(axis, n_deg * ARW_TO_SI, k_deg * RRW_TO_SI, n_from, k_from,
                     float(max(ratio[worst], 1.0)), float(fitted.tau_s[worst]), left_out,
                     fitted.trustworthy, walk)


def _level(terms: dict[str, dict], name: str, axis: str | None) -> tuple[float, str]:
    entry = terms.get(name)
    if entry is None:
        raise GyroidInputError(f"noise.json{'' if axis is None else f' of axis {axis}'} has "
                               f"no term {name}: run 'gyroid noise' again")
    if entry.get("resolved"):
        return float(entry["mean"]), "posterior mean"
    return float(entry["upper_bound_95"]), "95 % upper bound (not resolved by the log)"


@dataclass(frozen=True)
class NoiseExport:
    """An estimator's IMU noise file: its name and text, and ``export.json``'s record."""

    target: str
    file_name: str
    record: dict
    comments: tuple[str, ...]
    noise_density: float
    random_walk: float
    update_rate_hz: float | None
    topic: str

    @property
    def trustworthy(self) -> bool:
        """Whether every exported axis's noise fit passed its own checks."""
        return all(a["source_trustworthy"] for a in self.record["axes"].values())

    def text(self) -> str:
        """The YAML file (Kalibr's ``imu.yaml`` or OpenVINS's ``kalibr_imu_chain.yaml``)."""
        head = [f"# {c}" for c in self.comments]
        body = [f"gyroscope_noise_density: {self.noise_density:.6e}  # rad/s/sqrt(Hz)",
                f"gyroscope_random_walk: {self.random_walk:.6e}  # rad/s^2/sqrt(Hz)",
                "# accelerometer_noise_density:  # m/s^2/sqrt(Hz): not fitted by gyroid",
                "# accelerometer_random_walk:  # m/s^3/sqrt(Hz): not fitted by gyroid",
                f"rostopic: {self.topic}",
                (f"update_rate: {self.update_rate_hz:.6g}  # Hz" if self.update_rate_hz
                 else "# update_rate:  # Hz: fill in the IMU's rate")]
        if self.target == "kalibr":
            return "\n".join([*head, *body]) + "\n"
        identity = [f"    - [{', '.join('1.0' if i == j else '0.0' for j in range(4))}]"
                    for i in range(4)]
        chain = ["imu0:", "  T_i_b:", *identity, *(f"  {line}" for line in body),
                 "  time_offset: 0.0", '  model: "kalibr"']
        return "\n".join(["%YAML:1.0", *head, "", *chain]) + "\n"


def export_noise(axes: dict[str | None, AxisNoise], target: str, *, sample_s: float,
                 topic: str = "/imu0") -> NoiseExport:
    """The ``target`` (kalibr or openvins) noise file for a noise fit's axes: the largest
    level over the axes (module docstring)."""
    if target not in NOISE_TARGETS:
        raise GyroidInputError(f"--to {target!r}: a noise fit exports to "
                               f"{' or '.join(NOISE_TARGETS)}")
    density = max(a.noise_density for a in axes.values())
    walk = max(a.random_walk for a in axes.values())
    record = {"target": target, "gyroscope_noise_density": density,
              "gyroscope_random_walk": walk,
              "units": {"gyroscope_noise_density": "rad/s/sqrt(Hz)",
                        "gyroscope_random_walk": "rad/s^2/sqrt(Hz)"},
              "rule": "the largest over the axes; a walk the log does not resolve is its 95 % "
                      "upper bound",
              "update_rate_hz": 1.0 / sample_s,
              "axes": {str(a.axis or "x"): _axis_record(a) for a in axes.values()},
              "understated_note": "the largest factor by which white noise + bias random walk "
                                  "under-states the fitted model's Allan deviation over the "
                                  "log's averaging times (terms the target cannot represent)"}
    return NoiseExport(target, FILE_NAMES[target], record, _comments(axes), density, walk,
                       1.0 / sample_s, topic)


def _axis_record(a: AxisNoise) -> dict:
    return {"gyroscope_noise_density": a.noise_density, "density_from": a.density_from,
            "gyroscope_random_walk": a.random_walk, "walk_from": a.walk_from,
            "left_out": a.left_out, "understated_by": a.understated_by,
            "worst_tau_s": a.worst_tau_s, "source_trustworthy": a.trustworthy,
            "flicker_walk": a.flicker_walk, "flicker_walk_horizon_s": HORIZON_S}


def _comments(axes: dict[str | None, AxisNoise]) -> tuple[str, ...]:
    out = ["gyroid noise fit: white noise and bias random walk, the largest over the axes "
           f"({', '.join(str(a or 'x') for a in axes)}); per axis: export.json beside this file"]
    for axis, a in axes.items():
        name = axis or "x"
        out.append(f"axis {name}: gyroscope_noise_density = N (pi/180) / 60 = "
                   f"{a.noise_density:.6e} rad/s/sqrt(Hz); gyroscope_random_walk = K (pi/180) "
                   f"/ 3600 / 60 = {a.random_walk:.6e} rad/s^2/sqrt(Hz)")
        if a.flicker_walk is not None:
            out.append(f"axis {name}: bias instability has no term in this model; the walk "
                       f"over-bounding the fitted flicker (B's 95 % upper end) from "
                       f"{HORIZON_S:g} s on is {a.flicker_walk:.6e} rad/s^2/sqrt(Hz): use it "
                       "for gyroscope_random_walk where the estimator must not be "
                       "over-confident beyond that (in place of a fixed 10-20x)")
        if a.walk_from != "posterior mean":
            out.append(f"axis {name}: the random walk is the 95 % upper bound: the log is too "
                       "short to resolve it")
        if a.understated_by > 1.1:
            left = ", ".join(f"{k} = {v:.3g}" for k, v in a.left_out.items()) or "none resolved"
            out.append(f"axis {name}: white + random walk under-states the fitted Allan "
                       f"deviation by up to {a.understated_by:.2f}x (at tau = "
                       f"{a.worst_tau_s:.3g} s); left out: {left}")
        if not a.trustworthy:
            out.append(f"axis {name}: its noise fit is NOT trustworthy (noise.json checks)")
    out.append("accelerometer values: fill in from an accelerometer characterisation")
    return tuple(out)
