"""The demo's two processes: the steps that need no fit run in a second one, and if that
process dies its steps run in the first (no half-written report, no raw traceback)."""

from __future__ import annotations

import os
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest

from gyroid._config import ONE_CORE_ENVIRONMENT, one_core_environment
from gyroid.pipeline import _demo


class _Steps:
    """A stand-in for the demo's study that records which steps ran where."""

    def __init__(self):
        self.stage, self.seed, self.size, self.ran, self.said = Path("."), 0, None, [], []
        self.results = {}

    def echo(self, message):
        self.said.append(message)

    def __getattr__(self, name):
        if name in ("simulate", "fit", "propagate", "compensate_and_reproduce",
                    "discrepancy", "pool"):
            return lambda: self.ran.append(name)
        raise AttributeError(name)


class _Executor:
    """A process pool whose one job ends as ``outcome`` (a result dict or an exception)."""

    def __init__(self, outcome):
        self.outcome, self.submitted = outcome, []

    def __call__(self, *_args, **_kwargs):
        return self

    def __enter__(self):
        return self

    def __exit__(self, *_exc):
        return False

    def submit(self, function, *args):
        self.submitted.append((function, args))
        future = Future()
        if isinstance(self.outcome, BaseException):
            future.set_exception(self.outcome)
        else:
            future.set_result(self.outcome)
        return future


def test_the_second_process_results_join_the_study(monkeypatch):
    executor = _Executor({"discrepancy": "found", "pooled": "pool", "lot": "lot"})
    monkeypatch.setattr(_demo, "ProcessPoolExecutor", executor)
    study = _Steps()
    _demo._run_in_two_processes(study)
    assert study.ran == ["simulate", "fit", "propagate", "compensate_and_reproduce"]
    assert executor.submitted[0][0] is _demo._side_steps
    assert study.results == {"discrepancy": "found", "pooled": "pool", "lot": "lot"}


def test_a_dead_second_process_has_its_steps_run_here(monkeypatch):
    monkeypatch.setattr(_demo, "ProcessPoolExecutor",
                        _Executor(BrokenProcessPool("killed by the system")))
    study = _Steps()
    _demo._run_in_two_processes(study)
    assert study.ran == ["simulate", "fit", "propagate", "compensate_and_reproduce",
                         "discrepancy", "pool"]
    assert any("killed by the system" in line for line in study.said)


def test_the_one_core_environment_is_restored_and_keeps_the_users_xla_flags(monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "--xla_dump_to=/tmp/x")
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    with one_core_environment():
        flags = os.environ["XLA_FLAGS"]
        assert flags.startswith(ONE_CORE_ENVIRONMENT["XLA_FLAGS"])
        assert flags.endswith("--xla_dump_to=/tmp/x")  # the user's, last, wins
        assert os.environ["OMP_NUM_THREADS"] == "1"
    assert os.environ["XLA_FLAGS"] == "--xla_dump_to=/tmp/x"
    assert "OMP_NUM_THREADS" not in os.environ


def test_without_a_second_process_every_step_runs_here(monkeypatch):
    def refused(*_args, **_kwargs):
        raise OSError("no POSIX semaphores")

    monkeypatch.setattr(_demo, "ProcessPoolExecutor", refused)
    study = _Steps()
    _demo._run_in_two_processes(study)
    assert study.ran == ["simulate", "fit", "propagate", "compensate_and_reproduce",
                         "discrepancy", "pool"]
    assert any("no POSIX semaphores" in line for line in study.said)


@pytest.mark.slow
def test_a_failing_step_here_stops_the_second_process(tmp_path):
    """A real spawned second process: a step here fails, and the error arrives without the
    second process's steps (it is stopped, not waited for: it never reaches the pool)."""
    import multiprocessing

    from gyroid.errors import GyroidInputError

    class Failing(_Steps):
        def __getattr__(self, name):
            if name == "fit":
                def fail():
                    raise GyroidInputError("a bad step")
                return fail
            return super().__getattr__(name)

    study = Failing()
    study.stage, study.size = tmp_path, _demo.DemoSize(propagate_draws=10, sobol_samples=10)
    before = set(multiprocessing.active_children())
    with pytest.raises(GyroidInputError, match="a bad step"):
        _demo._run_in_two_processes(study)
    assert not set(multiprocessing.active_children()) - before
    assert not (tmp_path / "pool").exists()
