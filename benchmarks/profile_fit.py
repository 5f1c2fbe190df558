"""Where a default fit's time goes, in one process (issue 45's method: profile first).

A thermal bench log (paper A's schedule, ``--rows`` rows, as ``benchmarks/scaling.py`` makes
it) read and fitted with every default (``fit_log``, IEEE 952 noise, importance sampling):

* ``seconds``: the read, the first fit in the process (its programs traced and lowered, read
  back from JAX's persistent cache), the warm fit (median of ``--repeat``), writing its
  outputs (fit.json, posterior.nc, two figures) and, within that, the block
  log-likelihoods posterior.nc stores for leave-one-out;
* ``stages_s``: a warm fit under cProfile, the cumulative seconds of each stage (one may
  hold another: the window search builds a density per window, each matching the
  thermometer's rate error);
* ``compiled_share``: of that profiled fit, the share spent in compiled XLA calls and in
  waiting for their results (equinox's dispatch, NumPy's conversion of device arrays, and
  the main thread's wait for a batch's worker threads).

    python benchmarks/profile_fit.py --json benchmarks/results_profile_fit.json
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import tempfile
import time
from pathlib import Path

from _report import report
from scaling import make_log

#: The stages of a default bench fit: (file, function) -> name.
STAGES = {
    ("bench/_rate_window_marginal.py", "marginal_window"): "rate_window_marginal_search",
    ("bench/_rate_window.py", "choose_rate_window"): "rate_window_least_squares",
    ("noise/_rate_error_process.py", "matched"): "thermometer_rate_error_match",
    ("bench/_point.py", "point_estimate"): "final_mode",
    ("inference/_importance.py", "sample"): "importance_sampling",
    ("bench/_allowed_noise.py", "allowed_noise"): "noise_priors_check",
    ("bench/_checks.py", "bench_checks"): "other_checks",
}
#: The calls whose own time is compiled work or waiting for it (on the main thread: a batch
#: of evaluations runs on worker threads, which the main thread waits for on a lock).
COMPILED = {("equinox/_jit.py", "_call"), ("~", "<built-in method numpy.asarray>"),
            ("~", "<method 'acquire' of '_thread.lock' objects>")}


def _stages(stats: pstats.Stats) -> tuple[dict[str, float], float, float]:
    """Each stage's cumulative seconds, the compiled calls' own seconds, and the total."""
    stages = {name: 0.0 for name in STAGES.values()}
    compiled = 0.0
    for (path, _, function), (_, _, own, cumulative, _) in stats.stats.items():
        for (suffix, wanted), name in STAGES.items():
            if path.endswith(suffix) and function == wanted:
                stages[name] += cumulative
        if any(path.endswith(s) and function == f for s, f in COMPILED):
            compiled += own
    return stages, compiled, stats.total_tt


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=float, default=1e4)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    started = time.perf_counter()
    import gyroid
    from gyroid.bench import fit_log
    from gyroid.inference._storage import block_log_likelihood
    from gyroid.io._bench_reader import bench_log_from_table
    from gyroid.io._tables import read_log_table
    from gyroid.models._drift import DriftModel
    from gyroid.reports._write import write

    gyroid.configure()
    seconds = {"imports": time.perf_counter() - started}
    with tempfile.TemporaryDirectory() as scratch:
        path = make_log(int(args.rows), Path(scratch))
        model = DriftModel.from_terms("thermal")
        start = time.perf_counter()
        log = bench_log_from_table(read_log_table(path, (), None), model, axis=None)
        seconds["read"] = time.perf_counter() - start
        start = time.perf_counter()
        fit = fit_log(log, model, seed=0, progress=False)
        seconds["first_fit"] = time.perf_counter() - start
        warm = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            fit = fit_log(log, model, seed=0, progress=False)
            warm.append(time.perf_counter() - start)
        seconds["warm_fit"] = statistics.median(warm)
        seconds["warm_fit_all"] = warm
        out = Path(scratch) / "fit"
        out.mkdir()
        start = time.perf_counter()
        write(out, fit)
        seconds["write"] = time.perf_counter() - start
        start = time.perf_counter()
        block_log_likelihood(fit.problem, fit.posterior)
        seconds["block_log_likelihoods"] = time.perf_counter() - start
        profiler = cProfile.Profile()
        profiler.enable()
        fit_log(log, model, seed=0, progress=False)
        profiler.disable()
    stages, compiled, total = _stages(pstats.Stats(profiler))
    report({"date": time.strftime("%Y-%m-%d"), "rows": int(args.rows), "terms": "thermal",
            "seconds": seconds, "profiled_fit_s": total, "stages_s": stages,
            "compiled_share": compiled / total}, args.json)


if __name__ == "__main__":
    main()
