"""The predictive check of a roll fit (:mod:`gyroid.inference._predictive`).

The flight's observed rows are cut into contiguous stretches; each is left out in turn and
the loop refitted by its mode on the rest (the Kalman filter predicts through the held-out
rows instead of learning from them; every fold shares one compilation), its noise levels
held at the whole fit's. The stretch's
stabiliser angle is then predicted from the training fit and from the rows before it: the
loop's prediction plus the filter's estimate of the SINS gyro noise integrated so far. The
errors of that prediction have an exact covariance, ``P + q min(s_i, s_j) + r [i = j]``
(the walk's variance at the stretch's start, the walk's growth over the samples ``s`` since
then, the encoder's read-out noise), to which the training fit's parameter uncertainty is
added through the Jacobian of the prediction.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from gyroid.inference._check_report import Check
from gyroid.inference._predictive import HeldOut, part_means, predictive_check, stretches
from gyroid.inference._problem import PointEstimate
from gyroid.roll._density import ModelDensity

if TYPE_CHECKING:
    from gyroid.roll._problem import RollProblem


@eqx.filter_jit
def _expected(density: ModelDensity, u, n_model: int):
    """The stabiliser angle expected at every observed row from the rows learnt from before
    it (deg), the variance of the integrated gyro noise in that expectation (deg^2), and the
    expectation's Jacobian in the model's coordinates ``u[:n_model]`` (deg per unit)."""
    full = density.full
    angle = full.gs_angle[full.observed]

    def expectation(u_model):
        innovation, total = full.innovations(density.spread(
            jnp.concatenate([u_model, u[n_model:]])))
        return angle - innovation, total

    value, total = expectation(u[:n_model])
    jacobian = jax.jacfwd(lambda m: expectation(m)[0])(u[:n_model])
    sigma_gs = density.full.parameters(density.spread(u))["sigma_gs_deg"]
    return value, total - sigma_gs**2, sigma_gs**2, jacobian


def roll_predictive(problem: RollProblem, point: PointEstimate) -> Check:
    """The predictive check of a roll problem's fit, ``point`` its mode on the whole flight
    (see the module docstring)."""
    folds, part_s = roll_held_out(problem, point)
    return predictive_check(folds, part_s=part_s,
                            subject=f"held out in {len(folds or ())} stretches of the flight")


def roll_held_out(problem: RollProblem, point: PointEstimate
                  ) -> tuple[list[HeldOut] | None, float | None]:
    """The held-out folds of a roll fit and the median part's duration (s); None when the
    flight is too short to hold a stretch out."""

    full = problem.density.full
    observed = np.asarray(full.observed)
    parts = stretches(observed.size)
    if parts is None:
        return None, None
    angle = np.asarray(full.gs_angle)[observed]
    folds = []
    for k in range(int(parts.fold_of.max()) + 1):
        rows = parts.rows_of_fold(k)
        held = parts.fold_of == k
        masked = eqx.tree_at(lambda q: q.density.full, problem, full.without_rows(rows))
        fold_point = masked.mode()
        # The loop refitted, its noise levels as the fit states them: the walk is weakly
        # seen on a part of a flight (its mode can collapse on 80 % of one), and the bands
        # a user relies on are the whole fit's.
        u = np.concatenate([fold_point.u[:problem.n_model], point.u[problem.n_model:]])
        value, walk_var, read_var, jacobian = (np.asarray(a) for a in _expected(
            masked.density, jnp.asarray(u), problem.n_model))
        index = np.flatnonzero(rows)  # the stretch's rows, in time order
        # Within the stretch nothing is learnt: the walk's variance grows from its start,
        # so two rows' errors share the variance at the earlier of them.
        earlier = np.minimum.outer(np.arange(index.size), np.arange(index.size))
        noise = walk_var[index][earlier] + float(read_var) * np.eye(index.size)
        labels = parts.part[index]
        merge = (labels[None, :] == np.flatnonzero(held)[:, None]).astype(float)
        counts = merge.sum(axis=1)
        merge /= counts[:, None]
        model = merge @ jacobian[index] @ fold_point.covariance_u[:problem.n_model,
                                                                 :problem.n_model]
        folds.append(HeldOut(
            observed=part_means(angle, parts.part, parts.n_parts)[held],
            predicted=part_means(value, parts.part, parts.n_parts)[held],
            covariance=model @ (merge @ jacobian[index]).T + merge @ noise @ merge.T,
            counts=counts))
    time_s = np.asarray(full.time_s)[observed]
    durations = [np.ptp(time_s[parts.part == s]) for s in range(parts.n_parts)]
    return folds, float(np.median(durations)) or None
