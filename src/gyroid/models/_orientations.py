"""What a log's orientations tell about the overload effects (paper A eq. 1): the distinct
directions of the specific force it dwells in, which combinations of the bias and the
g-sensitivities those leave undetermined, and which orientation would settle them.

Three orientations and a constant cannot pin three sensitivities and a bias: with the
specific force along +X, +Y and +Z, ``w0 + nx``, ``w0 + ny`` and ``w0 + nz`` are measured
and ``w0 - nx - ny - nz`` is not; turning the unit to -X (or any direction off the plane
the three span) settles it.
"""

from __future__ import annotations

import numpy as np

from gyroid.models._drift import DriftModel
from gyroid.models._inputs import DriftInputs

#: Two dwell directions closer than this (g) are one orientation.
SAME_ORIENTATION_G = 0.15
#: A dwell is the specific force's mean over this long, s.
DWELL_S = 60.0
#: A combination whose design singular value is below this (g units) is unresolved.
RESOLVED_SINGULAR = 0.05

_AXIS_VECTORS = {f"{sign}{axis.upper()}": sign_v * np.eye(3)[k]
                 for k, axis in enumerate("xyz") for sign, sign_v in (("+", 1.0), ("-", -1.0))}


def orientations(inputs: DriftInputs) -> np.ndarray:
    """The distinct specific-force vectors (g) the log dwells at: the means of its
    ``DWELL_S`` blocks over which the specific force stays within ``SAME_ORIENTATION_G``
    (a block during a turn is no dwell), clustered within ``SAME_ORIENTATION_G``, shape
    (k, 3)."""
    if inputs.accel_g is None:
        return np.zeros((0, 3))
    time_s = np.asarray(inputs.time_h) * 3600.0
    accel = np.asarray(inputs.accel_g)
    index = np.floor((time_s - time_s[0]) / DWELL_S).astype(int)
    counts = np.bincount(index)
    spread = np.zeros(counts.size)
    for k in range(3):
        high = np.full(counts.size, -np.inf)
        low = np.full(counts.size, np.inf)
        np.maximum.at(high, index, accel[:, k])
        np.minimum.at(low, index, accel[:, k])
        spread = np.maximum(spread, np.where(counts > 0, high - low, np.inf))
    keep = (counts > 0) & (spread < SAME_ORIENTATION_G)
    means = np.stack([np.bincount(index, accel[:, k])[keep] / counts[keep] for k in range(3)],
                     axis=1)
    found: list[np.ndarray] = []
    for vector in means:
        if not any(np.linalg.norm(vector - other) < SAME_ORIENTATION_G for other in found):
            found.append(vector)
    return np.array(found)


def _overload_columns(model: DriftModel) -> list[tuple[str, int, int]]:
    """(parameter, axis index, power) of the model's overload terms."""
    out = []
    for effect in model.effects:
        if effect.name.startswith("overload"):
            power = 2 if "_sq_" in effect.name else 1
            out.append((effect.parameters[0].name, "xyz".index(effect.name[-1]), power))
    return out


def _design(vectors: np.ndarray, columns, with_bias: bool) -> np.ndarray:
    parts = [np.ones(len(vectors))] if with_bias else []
    parts += [vectors[:, k] ** power for _, k, power in columns]
    return np.column_stack(parts) if parts else np.zeros((len(vectors), 0))


def unresolved(model: DriftModel, inputs: DriftInputs) -> str | None:
    """A sentence naming the combinations of the bias and the overload coefficients the
    log's orientations leave undetermined and an orientation that would settle them; None
    when the orientations pin every one (or the model has no overload term)."""
    columns = _overload_columns(model)
    if not columns:
        return None
    with_bias = "bias" in model.terms
    names = (["w0"] if with_bias else []) + [name for name, _, _ in columns]
    seen = orientations(inputs)
    design = _design(seen, columns, with_bias)
    null = _null_space(design, len(names))
    if null.shape[1] == 0:
        return None
    if null.shape[1] == 1:
        what = _combination(null[:, 0], names)
    else:
        involved = [n for n, w in zip(names, np.abs(null).max(axis=1), strict=True) if w > 0.05]
        what = f"{null.shape[1]} combinations of {', '.join(involved)}"
    helpful = [label for label, v in _AXIS_VECTORS.items()
               if _null_space(np.vstack([design, _design(v[None, :], columns, with_bias)]),
                              len(names)).shape[1] < null.shape[1]]
    where = "; ".join("(" + ", ".join(f"{round(c, 2) + 0.0:+.2f}" for c in v) + ") g" for v in seen)
    advice = (f"a dwell with the specific force along {' or '.join(helpful[:3])} would "
              "resolve " + ("it" if null.shape[1] == 1 else "one of them")) if helpful else (
        "dwells at more orientations (or a centrifuge's levels) would resolve them")
    return (f"the log's {len(seen)} orientation{'s' if len(seen) != 1 else ''} ({where}) "
            f"leave{'s' if len(seen) == 1 else ''} {what} undetermined; {advice}")


def _null_space(design: np.ndarray, p: int) -> np.ndarray:
    if design.shape[0] == 0:
        return np.eye(p)
    _, singular, vt = np.linalg.svd(design, full_matrices=True)
    rank = int(np.sum(singular > RESOLVED_SINGULAR))
    return vt[rank:].T


def _combination(vector: np.ndarray, names: list[str]) -> str:
    """``w0 - nx - ny - nz``: a null direction, its first coefficient +1."""
    leading = vector[np.flatnonzero(np.abs(vector) > 1e-9 * np.max(np.abs(vector)))[0]]
    vector = vector / leading
    parts = []
    for c, name in zip(vector, names, strict=True):
        if abs(c) < 0.05:
            continue
        size = "" if abs(abs(c) - 1.0) < 0.01 else f"{abs(c):.2g} "
        parts.append(("-" if c < 0 else "+") + f" {size}{name}")
    return " ".join(parts).removeprefix("+ ")
