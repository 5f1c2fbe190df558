"""Batches of evaluations on several threads (gyroid.inference._batching.in_chunks): the
same numbers, in the same order, as one thread; the thread count read from the
environment."""

import numpy as np
import pytest

from gyroid import BenchLog
from gyroid._config import ONE_CORE_ENVIRONMENT, compute_threads
from gyroid.bench import BenchOptions, BenchProblem
from gyroid.inference._batching import in_chunks, problem_batcher


@pytest.mark.slow  # compiles its own programs: 8 s of the quick signal with an empty cache
def test_threads_give_one_threads_numbers(monkeypatch):
    """A collapsed marginal's solutions at 1100 noise levels, 250 a chunk (five chunks, the
    last padded): two threads return the one thread's array exactly."""
    rng = np.random.default_rng(3)
    n = 600
    temperature = np.linspace(15.0, 35.0, n)
    drift = (0.8 + 0.05 * (temperature - 21.0) + np.cumsum(rng.normal(0.0, 0.01, n))
             + rng.normal(0.0, 0.2, n))
    log = BenchLog(columns={"time_s": np.arange(n, dtype=float),
                            "temperature_C": temperature, "drift_deg_h": drift})
    problem = BenchProblem.from_log(log, "bias,temperature", BenchOptions(noise="white+flicker+rw"))
    collapsed = problem.collapsed()
    levels = np.asarray(collapsed.noise_loc) + rng.normal(0.0, 1.0, (1100, 3))
    batch = problem_batcher(collapsed.solved)
    monkeypatch.setenv("GYROID_THREADS", "1")
    one = in_chunks(batch, levels, 250)
    monkeypatch.setenv("GYROID_THREADS", "2")
    two = in_chunks(batch, levels, 250)
    assert one.shape == (1100, collapsed.solved(levels[0]).size)
    np.testing.assert_array_equal(two, one)
    # each row is its own level's, not a neighbour chunk's (another compiled shape: the
    # same to rounding)
    np.testing.assert_allclose(two[[0, 637, 1099]], np.asarray(batch(levels[[0, 637, 1099]])),
                               rtol=1e-9)


@pytest.mark.parametrize(("setting", "expected"), [("3", 3), ("1", 1)])
def test_thread_count_from_the_environment(monkeypatch, setting, expected):
    monkeypatch.setenv("GYROID_THREADS", setting)
    assert compute_threads() == expected


def test_thread_count_defaults_to_the_usable_cores(monkeypatch):
    monkeypatch.delenv("GYROID_THREADS", raising=False)
    assert compute_threads() >= 1
    monkeypatch.setenv("GYROID_THREADS", "none")  # not a count: the cores again
    assert compute_threads() >= 1
    assert ONE_CORE_ENVIRONMENT["GYROID_THREADS"] == "1"
