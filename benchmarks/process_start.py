"""A new process's first fit, its largest programs traced or loaded (``gyroid._exported``).

Every command and every batch worker is a new process. With JAX's persistent compilation
cache warm, such a process still traces and lowers each program before the cache can give
back its compiled form; gyroid keeps its largest programs exported (``jax.export``) beside
that cache and loads them instead. Each way runs in ``--repeat`` fresh processes after one
that fills both stores, all in one run, nothing else running: the fit of paper A's bench
(``fit_log(..., "thermal")``, every default) timed from its call, JAX's monitoring events
summed (tracing, lowering to StableHLO, reading compiled programs back), and a warm fit in
the same process beside it (what the first fit would cost with nothing traced or loaded).

    python benchmarks/process_start.py --json benchmarks/results_process_start.json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap

from _report import report

_ONE_PROCESS = textwrap.dedent("""
    import collections, json, sys, time
    import jax, jax.monitoring
    spent = collections.Counter()
    jax.monitoring.register_event_duration_secs_listener(
        lambda event, seconds, **_: spent.update({event: seconds}))
    from gyroid import configure
    configure()
    from gyroid import _exported
    if sys.argv[1] == "traced":
        _exported.use_store(None)
    from gyroid.inference import fit_log
    from gyroid.simulation import simulate_thermal_bench
    logs = [simulate_thermal_bench(seed=seed).log for seed in (1, 2)]
    started = time.perf_counter()
    fit_log(logs[0], "thermal", seed=0)
    first = time.perf_counter() - started
    events = dict(spent)
    started = time.perf_counter()
    fit_log(logs[1], "thermal", seed=0)
    warm = time.perf_counter() - started
    name = "/jax/core/compile/"
    print(json.dumps({"first_fit_s": first, "warm_fit_s": warm,
                      "tracing_s": events.get(name + "jaxpr_trace_duration", 0.0),
                      "lowering_s": events.get(name + "jaxpr_to_mlir_module_duration", 0.0),
                      "cache_reads_s": events.get(
                          "/jax/compilation_cache/cache_retrieval_time_sec", 0.0)}))
""")


def one(way: str, cache: str) -> dict:
    done = subprocess.run([sys.executable, "-c", _ONE_PROCESS, way], check=True,
                          capture_output=True, text=True,
                          env={**os.environ, "GYROID_JAX_CACHE": cache})
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        for way in ("traced", "loaded"):  # fill the compilation cache and the store
            one(way, cache)
        runs = {way: [one(way, cache) for _ in range(args.repeat)]
                for way in ("traced", "loaded")}
    results = {way: {key: round(statistics.median(r[key] for r in rows), 3)
                     for key in rows[0]} for way, rows in runs.items()}
    results["runs"] = runs
    results["note"] = ("medians of fresh processes, JAX's persistent compilation cache warm; "
                       "'traced': exported programs off, 'loaded': read from the store")
    report(results, args.json)


if __name__ == "__main__":
    main()
