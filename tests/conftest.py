import jax
import matplotlib
import pytest

matplotlib.use("Agg")

import gyroid  # noqa: E402,F401  (turns on float64)


@pytest.fixture(autouse=True, scope="session")
def _float64():
    assert jax.config.jax_enable_x64, "gyroid must run JAX in float64"
