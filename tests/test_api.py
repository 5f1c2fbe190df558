"""The public surface: every name gyroid exports resolves, and the version is the package's."""

from importlib.metadata import version

import gyroid


def test_every_exported_name_resolves_and_the_version_is_the_installed_one():
    for name in gyroid.__all__:
        assert getattr(gyroid, name) is not None, name
    assert gyroid.__version__ == version("gyroid")
    assert callable(gyroid.fit_log) and callable(gyroid.find_roll_discrepancies)


def test_the_compilation_cache_is_on_by_default_and_can_be_moved_or_switched_off(tmp_path):
    import os
    import subprocess
    import sys

    probe = ("import gyroid, jax; gyroid.configure(); "
             "print(jax.config.jax_compilation_cache_dir)")

    def folder(**env) -> str:
        clean = {k: v for k, v in os.environ.items()
                 if k not in ("GYROID_JAX_CACHE", "JAX_COMPILATION_CACHE_DIR")}
        out = subprocess.run([sys.executable, "-c", probe], env=clean | env,
                             capture_output=True, text=True, check=True)
        return out.stdout.strip()

    assert folder(XDG_CACHE_HOME=str(tmp_path)) == str(tmp_path / "gyroid" / "jax")
    assert folder(GYROID_JAX_CACHE=str(tmp_path / "mine")) == str(tmp_path / "mine")
    assert folder(GYROID_JAX_CACHE="off") in ("", "None")


def test_a_bench_fits_options_are_checked_when_made():
    """A script's wrong option is one clear error naming it (and its command-line flag)
    before any log is read; the defaults are the command line's."""
    import math

    import pytest

    from gyroid import GyroidInputError
    from gyroid.bench import BenchOptions

    default = BenchOptions()
    assert default.noise_model.name == "white+flicker+rw" and default.rate_window_s is None
    assert default.noise_choice is not None and default.noise_choice.startswith("auto:")
    assert BenchOptions(noise="white").noise_choice is None  # asked for by name
    for bad, flag in (({"noise": "pink"}, "--noise 'pink'"),
                      ({"prior_set": "wide"}, "(--priors)"),
                      ({"t0_C": math.nan}, "(--t0)"),
                      ({"rate_window_s": -5.0}, "(--rate-window)")):
        with pytest.raises(GyroidInputError) as error:
            BenchOptions(**bad)
        assert flag in str(error.value), bad
    # a burst log's means are fitted only where the noise model does not carry the wander
    assert BenchOptions(noise="white", segment_means=True).fits_segment_means
    carried = BenchOptions(segment_means=True)
    assert not carried.fits_segment_means and "on the samples" in carried.noise_choice
