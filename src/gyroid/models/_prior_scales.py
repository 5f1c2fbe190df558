"""Prior sets for the drift model: scaled to the log by default, or chosen by the user.

``default`` (weakly informative, scaled to the log being fitted, so one command serves a
0.01 deg/h FOG and a 10^4 deg/h MEMS gyro):

* the drift scale ``D`` is the RMS of the logged drift (offset included), deg/h;
* a real coefficient ``w`` of a regressor ``x`` gets ``Normal(0, 10 D / s)`` with
  ``s = max(range of x in the log, the regressor's physical span)`` (the registry's
  ``Parameter.span``: 10 degC for w1, 100 degC^2 for w2, 10 degC/h for wD, 100 uT for the
  field terms, 1 h for w_trend, 1 for w0 and signs): over that span the coefficient may
  move the drift by about ten times what the log shows. ``w0`` gets ``Normal(0, 10 D)``;
* time constants keep the registry's log-normal priors (physical, not scaled);
* the white-noise level gets ``LogNormal(h, 3)`` with ``h`` the log's high-frequency level
  (sd of first differences over sqrt 2), the Gauss-Markov level ``LogNormal(h / 3, 3)``,
  its correlation time the registry's ``LogNormal(300 s, 2)``; under IEEE 952 noise, with
  ``d = h sqrt(step)`` the white density (deg/h sqrt(s)): ``N ~ LogNormal(d / 60, 3)``
  (deg/sqrt(h)), ``B`` and ``K ~ LogNormal(d / 1000, 3)`` (negligible a priori; each
  noise term states its own: :mod:`gyroid.noise._terms`).

The same scales, taken as sds in sampling coordinates, are the yardstick of the
identifiability check (:mod:`gyroid.inference._checks`), whatever prior set the fit uses.

``paper_a_fog``: the registry's priors, sized for paper A's FOG (w0 ~ N(0, 10) deg/h ...).
``flat``: improper flat priors on every model coefficient. A TOML file or ``--prior
NAME=normal(MU,SD)`` overrides single parameters.

A noise fit of the same gyro at rest (``gyroid noise``) gives the noise levels' priors
(:func:`gyroid.noise.priors_from_noise`).
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import ACCEL_COLUMNS, FIELD_COLUMNS, DriftInputs
from gyroid.models._priors import Flat, LogNormal, Normal, Prior

#: How many drift scales a coefficient may move the drift over its span, a priori.
SCALE_FACTOR = 10.0
PRIOR_SETS = ("default", "paper_a_fog", "flat")
@dataclass(frozen=True)
class PriorBasis:
    """The log-derived numbers behind the default priors (for fit.json)."""

    drift_scale_deg_h: float
    noise_level_deg_h: float
    spans: dict[str, float]  # the span s used per coefficient, regressor units

    def to_json(self) -> dict:
        return {"rule": "Normal(0, 10 D / s): D the drift's RMS, s = max(regressor range "
                        "in the log, physical span)",
                "drift_scale_deg_h": self.drift_scale_deg_h,
                "noise_level_deg_h": self.noise_level_deg_h, "spans": self.spans}


def log_scales(drift_deg_h: np.ndarray) -> tuple[float, float]:
    """(drift scale D, high-frequency noise level h) of a log, deg/h, both > 0."""
    drift = np.asarray(drift_deg_h, dtype=float)
    d = float(np.sqrt(np.mean(drift**2)))
    h = float(np.std(np.diff(drift)) / math.sqrt(2.0)) if drift.size > 2 else 0.0
    tiny = 1e-12
    d = max(d, h, tiny)
    return d, max(h, 1e-6 * d, tiny)


def default_priors(model: DriftModel, inputs: DriftInputs, drift_deg_h: np.ndarray
                   ) -> tuple[dict[str, Prior], PriorBasis]:
    """The default log-scaled priors of the model's parameters (a noise model scales its
    own levels' priors: :meth:`gyroid.noise.NoiseModel.default_priors`)."""
    d, h = log_scales(drift_deg_h)
    priors: dict[str, Prior] = {}
    spans: dict[str, float] = {}
    for effect in model.effects:
        ranges = (np.ptp(np.asarray(effect.design_columns(inputs)), axis=0) if effect.linear
                  else np.zeros(len(effect.parameters)))
        for p, seen in zip(effect.parameters, ranges, strict=True):
            if p.positive:
                priors[p.name] = p.prior
                continue
            span = max(float(seen), p.span)
            spans[p.name] = span
            priors[p.name] = Normal(0.0, SCALE_FACTOR * d / span)
    return priors, PriorBasis(d, h, spans)


def reference_sd(model: DriftModel, inputs: DriftInputs, drift_deg_h: np.ndarray
                 ) -> dict[str, float]:
    """Per model coefficient, the scale the identifiability check judges its posterior sd
    against (sampling coordinates): the default prior's sd, but for every coefficient except
    the bias scaled by the drift's variation about its mean (or the noise level, if larger)
    rather than its RMS. A constant bias says nothing about how well a slope must be known:
    on a MEMS gyro biased by 16 300 deg/h the RMS had let a temperature coefficient of
    4207 +/- 2955 deg/h/degC from a 0.47 degC span pass as pinned down."""
    priors, _ = default_priors(model, inputs, drift_deg_h)
    d, h = log_scales(drift_deg_h)
    variation = max(float(np.std(np.asarray(drift_deg_h, dtype=float))), h) / d
    out = {}
    for p in model.parameters:
        prior = priors[p.name]
        if isinstance(prior, Normal):
            out[p.name] = prior.scale * (1.0 if p.name == "w0" else variation)
        elif isinstance(prior, LogNormal):
            out[p.name] = prior.log_sd
        else:
            raise ValueError(f"{p.name}: a default prior is normal or log-normal, "
                             f"not {prior.describe()}")
    return out


def identifiability_hints(model: DriftModel, inputs: DriftInputs) -> dict[str, str]:
    """Per coefficient with a regressor: what the log needs to identify it (the registry's
    hint, or that its regressor vary more), with how much the regressor varied here."""
    from gyroid.models._orientations import unresolved

    hints = {}
    orientation_note = unresolved(model, inputs)
    for p in model.parameters:
        if p.regressor is None and p.hint is None:
            continue
        seen = ""
        if p.name == "wD":  # its regressor is the rate estimated from temperature_C
            seen = (f" (it spans {np.ptp(np.asarray(inputs.rate_C_h)):.3g} degC/h here, and "
                    "moves with the temperature itself where the two are collinear, as in an "
                    "exponential warm-up)")
        elif p.regressor == "temperature_C":
            seen = f" (it spans {np.ptp(np.asarray(inputs.temperature_C)):.3g} degC here)"
        elif p.regressor in FIELD_COLUMNS and inputs.field_rel is not None:
            k = FIELD_COLUMNS.index(p.regressor)
            seen = f" (it spans {100 * np.ptp(np.asarray(inputs.field_rel[:, k])):.3g} uT here)"
        elif p.regressor == "time_s":
            seen = f" (this one lasts {np.ptp(np.asarray(inputs.time_h)):.3g} h)"
        elif p.regressor in ACCEL_COLUMNS or (p.name == "w0" and orientation_note):
            if orientation_note:  # one sentence for every coefficient it ties together
                hints[p.name] = orientation_note[0].upper() + orientation_note[1:]
                continue
        advice = p.hint or f"{p.name} needs a log in which {p.regressor} varies more"
        hints[p.name] = advice + seen
    return hints


def choose_priors(model: DriftModel, inputs: DriftInputs, drift_deg_h: np.ndarray,
                  noise_priors: Mapping[str, Prior], *, prior_set: str = "default",
                  overrides: Mapping[str, Prior] | None = None
                  ) -> tuple[tuple[Prior, ...], PriorBasis]:
    """Priors in sampling order (model parameters, then the noise levels, whose priors
    ``noise_priors`` gives in order) for a prior set and per-parameter overrides. Noise
    levels keep proper priors under ``flat``."""
    if prior_set not in PRIOR_SETS:
        raise GyroidInputError(f"--priors {prior_set!r}: use one of {', '.join(PRIOR_SETS)} "
                               "or a .toml file")
    scaled, basis = default_priors(model, inputs, drift_deg_h)
    noise_names = tuple(noise_priors)
    overrides = dict(overrides or {})
    unknown = set(overrides) - set(model.parameter_names) - set(noise_names)
    if unknown:
        raise GyroidInputError(f"--prior: no parameter named {sorted(unknown)[0]!r} in this "
                               f"model (it has {', '.join(model.parameter_names + noise_names)})")
    chosen: list[Prior] = []
    for p in model.parameters:
        if prior_set == "flat":
            base: Prior = Flat()
        elif prior_set == "paper_a_fog":
            base = p.prior
        else:
            base = scaled[p.name]
        chosen.append(overrides.get(p.name, base))
    for name, base in noise_priors.items():
        chosen.append(overrides.get(name, base))
    return tuple(chosen), basis


_SPEC = re.compile(r"^\s*(normal|lognormal|flat)\s*\(\s*([^,()]*?)\s*(?:,\s*([^,()]*?)\s*)?\)\s*$",
                   re.IGNORECASE)


def parse_prior(text: str, where: str = "--prior") -> Prior:
    """``normal(MU, SD)``, ``lognormal(MEDIAN, LOG_SD)`` or ``flat()``."""
    match = _SPEC.match(text)
    if not match:
        raise GyroidInputError(f"{where}: {text!r} is not normal(MU,SD), lognormal(MEDIAN,"
                               "LOG_SD) or flat()")
    kind, a, b = match.group(1).lower(), match.group(2), match.group(3)
    if kind == "flat":
        if a:
            raise GyroidInputError(f"{where}: flat() takes no numbers")
        return Flat()
    try:
        first, second = float(a), float(b)
    except (TypeError, ValueError):
        raise GyroidInputError(f"{where}: {text!r} needs two numbers") from None
    if not (math.isfinite(first) and math.isfinite(second)) or second <= 0:
        raise GyroidInputError(f"{where}: {text!r}: the spread must be a positive number")
    if kind == "normal":
        return Normal(first, second)
    if first <= 0:
        raise GyroidInputError(f"{where}: {text!r}: a log-normal median must be positive")
    return LogNormal(first, second)


def parse_prior_assignments(items: tuple[str, ...] | list[str]) -> dict[str, Prior]:
    """``NAME=normal(MU,SD)`` items (``--prior``, repeatable)."""
    out = {}
    for item in items:
        name, sep, spec = item.partition("=")
        if not sep or not name.strip():
            raise GyroidInputError(f"--prior {item!r}: write NAME=normal(MU,SD)")
        out[name.strip()] = parse_prior(spec, f"--prior {name.strip()}")
    return out


def load_prior_file(path: str | Path) -> dict[str, Prior]:
    """Priors from a TOML file: ``NAME = "normal(MU, SD)"`` lines, at the top level or in a
    ``[priors]`` table."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise GyroidInputError(f"--priors {path}: no such file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise GyroidInputError(f"--priors {path}: not a valid TOML file ({error})") from None
    table = data.get("priors", data)
    out = {}
    for name, spec in table.items():
        if not isinstance(spec, str):
            raise GyroidInputError(f"--priors {path}: {name} must be a string such as "
                                   "\"normal(0, 5)\"")
        out[name] = parse_prior(spec, f"--priors {path}: {name}")
    return out


def resolve_prior_option(value: str | None, assignments: tuple[str, ...] = ()
                         ) -> tuple[str, dict[str, Prior]]:
    """The CLI's ``--priors`` and ``--prior`` to (prior set, overrides)."""
    prior_set, overrides = "default", {}
    if value:
        if value in PRIOR_SETS:
            prior_set = value
        elif value.endswith(".toml"):
            overrides = load_prior_file(value)
        else:
            raise GyroidInputError(f"--priors {value!r}: use one of {', '.join(PRIOR_SETS)} "
                                   "or a .toml file")
    overrides.update(parse_prior_assignments(assignments))
    return prior_set, overrides
