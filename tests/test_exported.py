"""Programs exported once and loaded after (gyroid._exported): a loaded program gives the
exported one's answer exactly, and anything its key names, changed, builds a new one."""

import os

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

from gyroid import _exported
from gyroid._exported import exported


class _Line(eqx.Module):
    slope: jax.Array
    label: str = eqx.field(static=True)
    power: float = eqx.field(static=True, default=2.0)


def _misfit(line: _Line, x, y, scale: float):
    residual = (y - line.slope * x) / scale
    return jnp.sum(jnp.abs(residual) ** line.power), optx.RESULTS.successful


_program = exported(_misfit)


@pytest.fixture
def store(tmp_path):
    _exported.use_store(tmp_path)
    yield tmp_path
    _exported.use_store()  # back to the compilation cache's folder


def _arguments(n=50, power=2.0):
    rng = np.random.default_rng(1)
    x = rng.standard_normal(n)
    return _Line(jnp.asarray(0.7), "a line", power), x, 0.7 * x + rng.standard_normal(n), 0.5


def test_a_loaded_program_gives_the_exported_ones_answer_exactly(store):
    args = _arguments()
    first, status = _program(*args)
    assert len(list(store.rglob("*.program"))) == 1
    _exported._PROGRAMS.clear()  # as a new process: the program is read from the store
    again, again_status = _program(*args)
    assert float(again) == float(first)  # the same program: bit for bit
    assert again_status == optx.RESULTS.successful == status  # an equinox output kept
    # and it is the function's answer (the traced program's, to rounding)
    assert float(first) == pytest.approx(float(eqx.filter_jit(_misfit)(*args)[0]), rel=1e-14)


def test_whatever_the_key_names_builds_a_new_program(store, monkeypatch):
    line, x, y, scale = _arguments()
    _program(line, x, y, scale)
    _program(line, x, y, scale)  # the same: nothing new
    assert len(list(store.rglob("*.program"))) == 1
    _program(*_arguments(n=60))  # another shape
    _program(_Line(line.slope, "a line", 1.0), x, y, scale)  # a static field
    _program(line, x, y, 0.25)  # a static number
    assert len(list(store.rglob("*.program"))) == 4
    _exported._PROGRAMS.clear()
    monkeypatch.setattr(_exported, "environment", lambda: "another gyroid or JAX")
    value, _ = _program(line, x, y, scale)  # another environment: built anew, same answer
    assert len(list(store.rglob("*.program"))) == 5
    assert float(value) == pytest.approx(float(eqx.filter_jit(_misfit)(line, x, y, scale)[0]),
                                         rel=1e-14)


def test_what_cannot_be_named_runs_unstored(store):
    twice = exported(lambda f, v: f(v) * 2.0, name="twice")
    assert float(twice(lambda v: jnp.sum(v), jnp.arange(3.0))) == 6.0
    assert not list(store.rglob("*.program"))
    # under an outer trace the program is traced into its caller, as filter_jit's would be
    outer = jax.jit(lambda x: _program(_Line(jnp.asarray(1.0), "l"), x, x, 1.0)[0])
    assert float(outer(jnp.arange(3.0))) == 0.0
    assert not list(store.rglob("*.program"))


def test_a_damaged_program_is_exported_again(store):
    args = _arguments()
    first, _ = _program(*args)
    (path,) = store.rglob("*.program")
    path.write_bytes(path.read_bytes()[:-40])  # a program cut short
    _exported._PROGRAMS.clear()
    again, _ = _program(*args)
    assert float(again) == float(first)
    assert _exported.opened(path.read_bytes()) is not None  # replaced by a sound one


def test_without_a_store_nothing_is_written(tmp_path):
    _exported.use_store(None)
    try:
        value, _ = _program(*_arguments())
        assert np.isfinite(float(value))
    finally:
        _exported.use_store()
    assert not list(tmp_path.iterdir())


def test_the_store_keeps_the_latest_environments(store, monkeypatch):
    args = _arguments()
    for k in range(_exported._ENVIRONMENTS + 2):
        monkeypatch.setattr(_exported, "environment", lambda k=k: f"environment {k:02d}")
        monkeypatch.setattr(_exported, "_PRUNED", [False])  # as a new process
        _exported._PROGRAMS.clear()
        _program(*args)
        os.utime(store / f"environment {k:02d}", (k, k))  # written in this order
    kept = sorted(p.name for p in store.iterdir())
    assert kept == [f"environment {k:02d}" for k in range(2, _exported._ENVIRONMENTS + 2)]
