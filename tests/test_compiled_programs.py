"""A process that compiles many programs drops them before it exhausts its memory mappings
(XLA aborts the interpreter when it cannot map a program: pytest workers and research loops
over logs of many shapes reached Linux's limit)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import gyroid
from gyroid import _compiled_programs as programs
from gyroid.bench import BenchOptions

pytestmark = pytest.mark.skipif(programs.mapping_limit() is None,
                                reason="no memory-mapping limit to read (not Linux)")


@jax.jit
def _program(x):
    return jnp.cumsum(jnp.sin(x) @ x.T, axis=0)


def _compile_shapes(count: int) -> None:
    for n in range(2, 2 + count):
        _program(jnp.ones((n, 3))).block_until_ready()


@pytest.mark.slow
def test_a_crowded_process_drops_its_compiled_programs(monkeypatch):
    _compile_shapes(40)
    assert _program._cache_size() >= 40
    before = programs.mapping_count()
    monkeypatch.setattr(programs, "mapping_limit", lambda: before)  # past half of it
    assert programs.release_if_crowded()
    assert _program._cache_size() == 0
    # each compiled program held at least a mapping (about 6 for one this small)
    assert programs.mapping_count() <= before - 40


def test_an_uncrowded_process_keeps_them(monkeypatch):
    _compile_shapes(5)
    held = _program._cache_size()
    monkeypatch.setattr(programs, "mapping_limit", lambda: 10 * programs.mapping_count())
    assert not programs.release_if_crowded()
    assert _program._cache_size() == held


def test_without_a_limit_nothing_is_dropped(monkeypatch):
    _compile_shapes(3)
    monkeypatch.setattr(programs, "mapping_limit", lambda: None)
    assert not programs.release_if_crowded()
    assert _program._cache_size() >= 3


def test_a_fit_looks_before_it_compiles(monkeypatch):
    """fit_log (the bench problem's build and fit()) checks the process's mappings."""
    _compile_shapes(3)
    rng = np.random.default_rng(0)
    log = gyroid.BenchLog({"time_s": np.arange(600.0),
                           "drift_deg_h": 1.0 + rng.normal(0.0, 0.5, 600)})
    monkeypatch.setattr(programs, "mapping_limit", lambda: 2)
    gyroid.fit_log(log, "bias", BenchOptions(noise="white"), sample=False, progress=False)
    # dropped before the fit compiled its own: none of this test's programs is left
    assert _program._cache_size() == 0


_NEAR_THE_LIMIT = r"""
import mmap, sys
import jax, jax.numpy as jnp
from gyroid import _compiled_programs as programs

jax.jit(lambda x: x + 1.0)(jnp.ones(2)).block_until_ready()  # XLA's own mappings first
# the process left with room for some 13 programs of ~44 mappings each
room = 570
filled = [mmap.mmap(-1, 4096)
          for _ in range(programs.mapping_limit() - programs.mapping_count() - room)]


def body(x):
    for k in range(10):  # some 10 kernels: ~44 mappings once compiled
        x = jnp.sort(x * (k + 1.0), axis=0) @ x.T + jnp.cumsum(x, axis=k % 2)
    return x


program = jax.jit(body)
for n in range(3, 28):  # 25 shapes, 25 programs
    if sys.argv[1] == "guarded":
        programs.release_if_crowded()
    program(jnp.ones((n, n))).block_until_ready()
print("all 25 compiled")
"""


@pytest.mark.slow
@pytest.mark.skipif((programs.mapping_limit() or 0) > 300_000,
                    reason="a mapping limit too high to fill in a test")
def test_near_the_limit_a_process_aborts_unless_it_drops_its_programs():
    """The failure itself, in a child process left with room for ~13 programs: compiling
    25 without dropping any aborts the interpreter inside XLA (SIGABRT, as the test
    workers and the loops over logs did); checking before each, as every fit does, it
    compiles all 25."""
    import subprocess
    import sys

    def run(arm: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-c", _NEAR_THE_LIMIT, arm],
                              capture_output=True, text=True, timeout=600)

    unguarded = run("unguarded")
    assert unguarded.returncode != 0 and "all 25 compiled" not in unguarded.stdout
    assert "allocate" in unguarded.stderr.lower(), unguarded.stderr[-2000:]
    guarded = run("guarded")
    assert guarded.returncode == 0, guarded.stderr[-2000:]
    assert "all 25 compiled" in guarded.stdout
