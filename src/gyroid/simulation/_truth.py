"""A simulated log's truth: which effects are on with which values (checked), and the record
of it (``truth.json``, the log's comment lines)."""

from __future__ import annotations

from collections.abc import Mapping

from gyroid.errors import GyroidInputError
from gyroid.models._drift import DriftModel
from gyroid.models._effects import EFFECTS, PARAMETERS
from gyroid.simulation._noise import GyroNoise


def resolve_truth(
    base: Mapping[str, float], effects: Mapping[str, Mapping[str, float]] | None
) -> tuple[tuple[str, ...], dict[str, float]]:
    """Effects switched on and their parameter values.

    An effect is on when ``base`` gives all its parameters or ``effects`` names it; values in
    ``effects`` override ``base``.
    """
    requested = dict(effects or {})
    values = {k: float(v) for k, v in base.items()}
    for name, params in requested.items():
        if name not in EFFECTS:
            raise GyroidInputError(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}")
        effect = EFFECTS[name]
        unknown = set(params) - set(effect.parameter_names)
        if unknown:
            raise GyroidInputError(
                f"effect {name!r} has parameters {', '.join(effect.parameter_names)}, "
                f"not {', '.join(sorted(unknown))}"
            )
        values.update({k: float(v) for k, v in params.items()})
        missing = [p for p in effect.parameter_names if p not in values]
        if missing:
            raise GyroidInputError(f"give a value for {missing[0]} of effect {name!r}")
    terms = tuple(
        name
        for name, e in EFFECTS.items()
        if name in requested or all(p in base for p in e.parameter_names)
    )
    used = {p for name in terms for p in EFFECTS[name].parameter_names}
    stray = sorted(set(values) - used)
    if stray:
        raise GyroidInputError(f"parameter {stray[0]!r} belongs to no effect that is switched on")
    for name in terms:
        for p in EFFECTS[name].parameters:
            if p.positive and values[p.name] <= 0:
                raise GyroidInputError(f"{p.name} must be positive, got {values[p.name]}")
    return terms, values


def truth_record(bench: str, model: DriftModel, values: Mapping[str, float], noise: GyroNoise,
                 sample_s: float, protocol: dict, average_s: float | None, seed: int,
                 t0_C: float) -> dict:
    """``truth.json`` of a simulated bench log."""
    return {
        "bench": bench,
        "effects": list(model.terms),
        "parameters": {name: values[name] for name in model.parameter_names},
        "units": {p: PARAMETERS[p].unit for p in model.parameter_names},
        "t0_C": t0_C,
        "noise": noise.as_dict() | {"white_sd_deg_h": noise.white_sd_deg_h(sample_s)},
        "protocol": protocol,
        "average_s": average_s,
        "seed": seed,
    }


def truth_comments(truth: dict) -> tuple[str, str]:
    """A simulated log's comment lines: what it is and its truth."""
    return (f"gyroid simulated {truth['bench']} bench, seed {truth['seed']}",
            "truth: " + ", ".join(f"{k}={v:g}" for k, v in truth["parameters"].items()))
