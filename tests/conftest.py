import os
from pathlib import Path

import jax
import pytest

import gyroid

#: The public real logs the tests read (gyroid's dataset registry finds them there; the
#: project commits none of them).
REAL_LOGS = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
os.environ.setdefault("GYROID_DATA", str(REAL_LOGS))

# float64 and the persistent compilation cache, as the command line sets them.
gyroid.configure()
# Strict promotion: an implicit int/float or precision mix in gyroid's JAX code is an
# error under test, not a silent cast (third-party code that needs standard promotion,
# blackjax's adaptation, is wrapped where gyroid calls it).
jax.config.update("jax_numpy_dtype_promotion", "strict")


@pytest.fixture(autouse=True, scope="session")
def _float64():
    assert jax.config.jax_enable_x64, "gyroid must run JAX in float64"


def pytest_sessionfinish(session, exitstatus):
    """Take JAX's garbage-collection callback off at the session's end: pytest collects
    garbage as it shuts down while pytest-xdist's channels interrupt the main thread, and an
    interrupt landing inside that callback was reported as an unraisable-exception warning
    (2 of 3 full runs). The callback only frees XLA's buffers early; nothing runs after."""
    import gc

    gc.callbacks[:] = [c for c in gc.callbacks
                       if getattr(c, "__name__", "") != "_xla_gc_callback"]


@pytest.fixture(autouse=True, scope="module")
def _room_for_programs():
    """After each module, drop the compiled programs if the worker holds more than half of
    its memory-mapping limit (:mod:`gyroid._compiled_programs`): a worker running hundreds
    of tests compiles thousands of programs, and the fits' own check covers only fits."""
    yield
    from gyroid._compiled_programs import release_if_crowded

    release_if_crowded()
