"""Fit a roll log in one call: :func:`fit_roll_log` builds a
:class:`~gyroid.roll.RollProblem` and fits it."""


from __future__ import annotations

from gyroid.inference._fit import fit
from gyroid.inference._problem import AbstractSampler
from gyroid.io._roll_log import RollLog
from gyroid.roll._problem import RollProblem
from gyroid.roll._result import RollFit


def fit_roll_log(log: RollLog, *, terms="loop", seed: int = 0,
                 sampler: AbstractSampler | None = None) -> RollFit:
    """Fit paper B's loop (``terms``, default ``loop``) to a roll log: the mode, the
    posterior (importance sampling, emcee where its weights fail; or ``sampler``'s), the
    self-checks."""
    return fit(RollProblem.from_log(log, terms), sampler=sampler, seed=seed)
