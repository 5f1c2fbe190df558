"""A bench model's columns at its positive parameters (a warm-up's time constant, a step's
time): the drift less the model at zero real coefficients, then the model's derivatives in
those (exact: every effect is linear in its real coefficients), what the marginal of
:mod:`gyroid.inference._collapsed` integrates the coefficients out of, computed for many
points side by side."""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid._exported import exported


def split_parameters(density) -> tuple[np.ndarray, np.ndarray]:
    """The indices of a density's real model parameters and of its positive ones (time
    constants, a step's time: entered through their logs)."""
    positive = np.array([q.positive for q in density.model.parameters], dtype=bool)
    return np.flatnonzero(~positive), np.flatnonzero(positive)


def model_columns(density, u_positive: Float[Array, " q"]) -> Float[Array, "n 1+r"]:
    """The drift less the model at zero real coefficients, then the model's derivatives in
    them (exact: every effect is linear in its real coefficients), at positive parameters
    ``u_positive`` (logs): what :func:`collapse` integrates the coefficients out of."""
    offset, design = density.model.columns_at(density.inputs, u_positive)
    return jnp.column_stack([density.drift - offset, design])


_columns_at = exported(eqx.filter_vmap(model_columns, in_axes=(None, 0)), name="model_columns")
#: Points of positive parameters whose columns are computed side by side (fewer are
#: padded: one compilation per model).
COLUMN_BATCH = 32


def chunks(rows: np.ndarray, size: int = COLUMN_BATCH):
    """``rows`` in runs of ``size``, the last padded by repeating its first row."""
    for start in range(0, len(rows), size):
        chunk = rows[start:start + size]
        if len(chunk) < size:
            chunk = np.concatenate([chunk, np.repeat(chunk[:1], size - len(chunk), axis=0)])
        yield chunk


def columns_at(density, points: np.ndarray) -> np.ndarray:
    """:func:`model_columns` at each row of ``points`` (positive parameters, logs), computed
    :data:`COLUMN_BATCH` rows at a time."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    return np.concatenate([np.asarray(_columns_at(density, jnp.asarray(chunk)))
                           for chunk in chunks(points)])[: len(points)]


def positive_log_prior(density, points: np.ndarray) -> np.ndarray:
    """The positive parameters' log-prior (normal in their logs, where they have one: the
    density's own terms) at each row of ``points`` (logs)."""
    _, positive = split_parameters(density)
    loc, scale, on = (np.asarray(a, dtype=float)[positive] for a in (
        density.prior_loc, density.prior_scale, density.prior_on))
    z = on * (np.atleast_2d(points) - loc) / scale
    return np.sum(-0.5 * z**2 - on * (np.log(scale) + 0.5 * math.log(2.0 * math.pi)), axis=1)
