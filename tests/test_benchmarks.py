"""The benchmark script's agreement checks (gyroid and the NumPy baseline must compute the
same thing before their times are compared); no timing is asserted."""

import importlib.util
from pathlib import Path

import pytest

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


@pytest.mark.slow
def test_the_bare_script_baseline_fits_the_same_coefficients(tmp_path):
    """benchmarks/scaling.py compares gyroid with benchmarks/bare_thermal_fit.py: that
    comparison is only fair if the bare script answers the same question."""
    import json
    import subprocess
    import sys

    from gyroid.bench import BenchOptions, fit_log
    from gyroid.inference import Emcee
    from gyroid.io import write_bench_log
    from gyroid.simulation import ThermalProtocol, simulate_thermal_bench

    protocol = ThermalProtocol()
    rate_hz = 2e4 / protocol.duration_s
    sim = simulate_thermal_bench(seed=3, protocol=protocol.stretched(None, rate_hz))
    path = write_bench_log(tmp_path / "log.parquet", sim.log.columns)
    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bare_thermal_fit.py"),
                          str(path)], capture_output=True, text=True, check=True)
    bare = json.loads(out.stdout.strip().splitlines()[-1])["mean"]
    ours = fit_log(sim.log, "thermal", BenchOptions(noise="white"), sampler=Emcee(progress=False))
    for name in ("w1", "wD"):
        summary = ours.posterior.summary[name]
        # Different dT/dt estimators: agreement within 3 posterior sd is the claim.
        assert abs(bare[name] - summary["mean"]) < 3 * summary["sd"], name


def test_the_profiles_stages_name_functions_the_library_defines(monkeypatch):
    """benchmarks/profile_fit.py sums cProfile's cumulative time per stage by file and
    function name: a renamed or moved function would read 0 s, silently (two stages did)."""
    import ast

    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # it imports its neighbours
    spec = importlib.util.spec_from_file_location("profile_fit",
                                                  ROOT / "benchmarks" / "profile_fit.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    for (file, function), stage in module.STAGES.items():
        [path] = (ROOT / "src" / "gyroid").rglob(file)
        defined = {node.name for node in ast.walk(ast.parse(path.read_text()))
                   if isinstance(node, ast.FunctionDef)}
        assert function in defined, f"{stage}: {file} defines no {function}"
