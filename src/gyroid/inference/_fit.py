"""One way to fit any problem: its mode, a posterior, then its result with the self-checks."""

from __future__ import annotations

from collections.abc import Callable

from gyroid._compiled_programs import release_if_crowded
from gyroid.inference._problem import AbstractProblem, AbstractSampler


def fit(problem: AbstractProblem, *, sampler: AbstractSampler | None = None, seed: int = 0,
        sample: bool = True, progress: Callable[[str], None] | None = None):
    """Fit ``problem``: the posterior mode (:meth:`~AbstractProblem.mode`), then, with
    ``sample=True``, its posterior by ``sampler`` (default: the problem's own, emcee for
    bench and roll logs, NUTS for a pooled lot) seeded by ``seed``, then the result, whose
    self-checks are computed before it is built (a frozen result of the problem's kind:
    :class:`~gyroid.inference.BenchFit`, :class:`~gyroid.inference.RollFit` or
    :class:`~gyroid.inference.PoolFit`). ``progress`` receives plain progress lines."""
    release_if_crowded()  # a long loop of fits must not exhaust the process's mappings
    point = problem.mode()
    posterior = None
    if sample:
        chosen = sampler if sampler is not None else problem.default_sampler()
        posterior = chosen.sample(problem, point, seed=seed, progress=progress)
    return problem.result(point, posterior, seed=seed)
