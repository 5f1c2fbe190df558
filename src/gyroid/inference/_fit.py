"""One way to fit any problem: its mode, a posterior, then its result with the self-checks.

The result's kind follows the problem's (:data:`RESULTS`): each result module imports its
problem one way, so the problem needs no knowledge of its result, and a result reads its
problem's concrete type.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from gyroid._compiled_programs import release_if_crowded
from gyroid.inference._bench_problem import BenchProblem
from gyroid.inference._bench_result import bench_result
from gyroid.inference._noise_model_fit import noise_model_result
from gyroid.inference._noise_problem import NoiseProblem
from gyroid.inference._pool_problem import PoolProblem
from gyroid.inference._pool_result import pool_result
from gyroid.inference._problem import AbstractProblem, AbstractSampler
from gyroid.inference._roll_problem import RollProblem
from gyroid.inference._roll_result import roll_result

#: Each kind of problem's result: its frozen result type, built with its self-checks.
RESULTS: dict[type, Callable[..., Any]] = {
    BenchProblem: bench_result, RollProblem: roll_result, PoolProblem: pool_result,
    NoiseProblem: noise_model_result}


def fit(problem: AbstractProblem, *, sampler: AbstractSampler | None = None, seed: int = 0,
        sample: bool = True, progress: Callable[[str], None] | None = None):
    """Fit ``problem``: the posterior mode (:meth:`~AbstractProblem.mode`), then, with
    ``sample=True``, its posterior by ``sampler`` (default: the problem's own, importance
    sampling for bench, roll and static-noise logs, NUTS for a pooled lot) seeded by
    ``seed``, then the result, whose self-checks are computed before it is built (a frozen
    result of the problem's kind, :data:`RESULTS`: :class:`~gyroid.inference.BenchFit`,
    :class:`~gyroid.inference.RollFit`, :class:`~gyroid.inference.PoolFit` or a noise
    model's fit). ``progress`` receives plain progress lines."""
    release_if_crowded()  # a long loop of fits must not exhaust the process's mappings
    point = problem.mode()
    posterior = None
    if sample:
        chosen = sampler if sampler is not None else problem.default_sampler()
        posterior = chosen.sample(problem, point, seed=seed, progress=progress)
    return RESULTS[type(problem)](problem, point, posterior, seed=seed)
