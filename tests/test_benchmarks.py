"""The benchmark script's agreement checks (gyroid and the NumPy baseline must compute the
same thing before their times are compared); no timing is asserted."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).parent.parent


def _benchmarks():
    spec = importlib.util.spec_from_file_location("benchmarks_run", ROOT / "benchmarks" / "run.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_benchmark_jobs_agree_with_their_baselines():
    bench = _benchmarks()
    problem, flat, design, y, scales = bench.bench_problems(0)
    assert bench.bench_likelihood(problem, design, y, scales, 1)
    assert bench.bench_point(flat, design, y, 1)
