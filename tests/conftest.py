import os
from pathlib import Path

import jax
import pytest

import gyroid

#: The project's shared folder of the public real logs, beside its checkout (gyroid's
#: dataset registry finds them there; the project commits none of them). A user's clone has
#: none: the registry then looks in its usual place (``gyroid datasets NAME`` fetches a log
#: there), and a test whose log is in neither skips, naming it (:func:`helpers.
#: require_dataset`). Only read: nothing is written there.
REAL_LOGS = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
if REAL_LOGS.is_dir():
    os.environ.setdefault("GYROID_DATA", str(REAL_LOGS))

# float64 and the persistent compilation cache, as the command line sets them.
gyroid.configure()
# Strict promotion: an implicit int/float or precision mix in gyroid's JAX code is an
# error under test, not a silent cast (third-party code that needs standard promotion,
# blackjax's adaptation, is wrapped where gyroid calls it).
jax.config.update("jax_numpy_dtype_promotion", "strict")


def pytest_configure(config):
    """Workers that share the cores compute on one core each (XLA's and the BLAS's thread
    pools off, :data:`gyroid._config.ONE_CORE_ENVIRONMENT`): two workers on two cores each
    spreading over both took twice the CPU time for the same tests (the hidden thermal
    effects' searches, -n 2: 255 s of CPU, 132 s; one core each: 129 s, 82 s). Set in the
    controller before its workers start, which inherit it."""
    workers = getattr(config.option, "numprocesses", None) or 0
    if hasattr(config, "workerinput") or not isinstance(workers, int) or workers < 1:
        return
    if workers >= (os.cpu_count() or 1):
        from gyroid._config import use_one_core

        use_one_core()


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


#: Test files that take longest on a new machine (cold: the README tour 175 s, the reduced
#: demo 94 s, the importance sampler's quadrature 83 s, the pools and the discrepancy
#: searches 40-55 s each), handed to the workers first: under ``--dist loadfile`` the files
#: go out in collection order, and one of these started last kept one worker busy for
#: minutes after the other had finished (longest first).
LONGEST_FIRST = ("test_discrepancy.py", "test_readme.py", "test_discrepancy_causes.py",
                 "test_cli.py", "test_importance.py", "test_pool_noise.py", "test_pool.py")


def pytest_collection_modifyitems(config, items):
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: files whole
