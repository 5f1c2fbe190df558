"""One way to fit any problem: its mode, a posterior, then the result the problem builds with
its self-checks (:meth:`~gyroid.inference.AbstractProblem.result`)."""

from __future__ import annotations

from collections.abc import Callable

from gyroid._compiled_programs import release_if_crowded
from gyroid.inference._problem import AbstractProblem, AbstractSampler, R


def fit(problem: AbstractProblem[R], *, sampler: AbstractSampler | None = None, seed: int = 0,
        sample: bool = True, progress: Callable[[str], None] | None = None) -> R:
    """Fit ``problem``: the posterior mode (:meth:`~AbstractProblem.mode`), then, with
    ``sample=True``, its posterior by ``sampler`` (default: the problem's own, importance
    sampling for bench, roll and static-noise logs, NUTS for a pooled lot) seeded by
    ``seed``, then the result, whose self-checks are computed before it is built (a frozen
    result of the problem's kind: :class:`~gyroid.bench.BenchFit`,
    :class:`~gyroid.roll.RollFit`, :class:`~gyroid.pool.PoolFit` or a noise model's fit).
    ``progress`` receives plain progress lines."""
    release_if_crowded()  # a long loop of fits must not exhaust the process's mappings
    point = problem.mode()
    posterior = None
    if sample:
        chosen = sampler if sampler is not None else problem.default_sampler()
        posterior = chosen.sample(problem, point, seed=seed, progress=progress)
    return problem.result(point, posterior, seed=seed)
