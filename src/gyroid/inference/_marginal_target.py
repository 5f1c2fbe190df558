"""What importance sampling (:mod:`gyroid.inference._importance`) integrates numerically
for a problem, and how a draw becomes a full parameter vector.

A bench fit's real coefficients are integrated out exactly (the one marginal of
:mod:`gyroid.inference._collapsed`: filtered under correlated noise, on sufficient
statistics under white noise). What is left, the *marginal coordinates*, is the noise levels
for a linear model, and the positive parameters (time constants, a step's time; logs) with
them for a model linear in its real coefficients given those (every catalogued effect; under
correlated noise): the marginal is then rebuilt at each draw's positive parameters from the
model's columns there, and their prior joins it. Either way, one evaluation per draw gives
the marginal log-posterior and the coefficients' conditional Gaussian, from which
:func:`~gyroid.inference._collapsed.conditional_draws` draws them.

Where nothing integrates out exactly (paper B's roll loop; a static log's noise terms) the
target is the whole posterior (:func:`whole_posterior`); so it is for a white model with
time constants, whose weighing on the rebuilt marginal cost more than it saved.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
from jax.typing import ArrayLike

from gyroid._exported import exported
from gyroid.inference._batching import problem_batcher
from gyroid.inference._collapsed import collapse, filtered_form
from gyroid.inference._model_columns import (
    COLUMN_BATCH,
    chunks,
    columns_at,
    positive_log_prior,
    split_parameters,
)


@dataclass(frozen=True)
class MarginalTarget:
    """The marginal coordinates' places in a parameter vector (sampling coordinates), the
    coefficients', the batched marginal (``solved``: rows ``(m, d) -> (m, 1 + r + r^2)``,
    :meth:`~gyroid.inference._collapsed.CollapsedCoefficients.solved`'s layout) and the
    noise levels' priors (``tails``: index among the marginal coordinates, the prior
    median's log, its log-sd)."""

    marginal: np.ndarray
    real: np.ndarray
    solved: Callable[[np.ndarray], np.ndarray]
    tails: list[tuple[int, float, float]]
    n_positive: int = 0  # the marginal coordinates' first ones: positive parameters
    what: str = ""  # what the coordinates are, where the problem says (a whole posterior)

    @property
    def describe(self) -> str:
        """What the marginal coordinates are, in words."""
        if self.what:
            return self.what
        levels = len(self.marginal) - self.n_positive
        return (("noise level" if levels == 1 else "noise levels") if self.n_positive == 0
                else f"noise levels and {self.n_positive} positive parameter(s)"
                if levels else "positive parameters")

    @property
    def size(self) -> int:
        return self.marginal.size + self.real.size

    def assemble(self, beta: np.ndarray, marginal: np.ndarray) -> np.ndarray:
        """Full parameter vectors (sampling coordinates) from coefficients and marginal
        coordinates, row by row."""
        u = np.empty((beta.shape[0], self.size))
        u[:, self.real], u[:, self.marginal] = beta, marginal
        return u


def _tails(collapsed, offset: int) -> list[tuple[int, float, float]]:
    """(index, prior median's log, prior log-sd) of each noise level with a prior, the
    indices shifted by ``offset`` marginal coordinates before the levels."""
    on = np.flatnonzero(np.asarray(collapsed.noise_on) > 0)
    loc, scale = np.asarray(collapsed.noise_loc), np.asarray(collapsed.noise_scale)
    return [(offset + int(i), float(loc[i]), float(scale[i])) for i in on]


@exported
def _solved_at(base, columns, levels):
    """:meth:`solved` of ``base`` with each of ``columns`` at the matching noise levels."""
    return jax.vmap(lambda c, v: base.with_columns(c).solved(v))(columns, levels)


def _whole(density) -> MarginalTarget:
    """:func:`whole_posterior` of a bench density (see :func:`marginal_target`)."""
    batch = problem_batcher(density.log_posterior)
    return whole_posterior(batch, density.positive, density.prior_loc, density.prior_scale,
                           density.prior_on, "coefficients and noise level"
                           if density.noise_names else "coefficients")


def whole_posterior(log_posterior: Callable[[np.ndarray], ArrayLike],
                    positive: Sequence[bool], prior_loc: ArrayLike, prior_scale: ArrayLike,
                    prior_on: ArrayLike, what: str) -> MarginalTarget:
    """The target of a problem with no coefficient to integrate out: every coordinate is a
    marginal one, ``log_posterior`` the batched log-posterior (``u (m, d) -> (m,)``). Each
    positive parameter with a prior (``prior_on``; its median's log ``prior_loc`` and
    log-sd ``prior_scale``, the sampling coordinates') is a tail the posterior may keep:
    a noise level, a time constant, a static log's noise term. ``what``: the coordinates,
    in words. A white-noise bench fit, a roll loop, a static log's noise terms."""
    loc, scale, on = (np.asarray(a, dtype=float) for a in (prior_loc, prior_scale, prior_on))
    tails = [(i, float(loc[i]), float(scale[i]))
             for i, kept in enumerate(np.asarray(positive, dtype=bool) & (on > 0)) if kept]

    def solved(u: np.ndarray) -> np.ndarray:
        return np.asarray(log_posterior(u), dtype=float)[:, None]

    return MarginalTarget(np.arange(len(positive)), np.zeros(0, dtype=int), solved, tails,
                          what=what)


def marginal_target(density) -> MarginalTarget:
    """What importance sampling weighs for a bench density: the noise levels (and under
    correlated noise the model's positive parameters), the real coefficients integrated
    out (:func:`~gyroid.inference._collapsed.collapse`; nothing left to weigh where every
    row's sd is given and the model is linear); otherwise (a white model with time
    constants) the whole posterior, each positive parameter's prior (the white level's, a
    time constant's) a tail it may keep."""
    real, positive = split_parameters(density)
    p, k = density.n_model, len(density.noise_names)
    levels = np.arange(p, p + k)
    if positive.size == 0:
        collapsed = collapse(density)
        if collapsed is None:
            return _whole(density)
        return MarginalTarget(levels, real, problem_batcher(collapsed.solved),
                              _tails(collapsed, 0))
    q = positive.size
    probe = np.zeros((1, q))  # any point: the form's columns are replaced at every draw
    base = filtered_form(density, jnp.asarray(columns_at(density, probe)[0]), real)
    if base is None:
        return _whole(density)

    def solved(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        rows = np.concatenate([
            np.asarray(_solved_at(base, jnp.asarray(columns_at(density, chunk[:, :q])),
                                  jnp.asarray(chunk[:, q:])))
            for chunk in chunks(x, COLUMN_BATCH)])[: len(x)]
        rows[:, 0] += positive_log_prior(density, x[:, :q])
        return rows

    return MarginalTarget(np.concatenate([positive, levels]), real, solved, _tails(base, q),
                          n_positive=q)
