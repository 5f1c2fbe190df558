"""A long log's design matrix in blocks of rows (src/gyroid/models/_design.py): the results must
not depend on the block size. Test logs are shorter than one default block, so the blocks
are made small here to exercise the multi-block path."""

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import SHORT_THERMAL

from gyroid import GyroidInputError
from gyroid.bench import BenchOptions, BenchProblem, choose_rate_window
from gyroid.io import BenchLog
from gyroid.models import DriftModel, least_squares_from_r, with_rows
from gyroid.models import _design as design
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.simulation import simulate_thermal_bench


@pytest.fixture(scope="module")
def log():
    return simulate_thermal_bench(seed=5, protocol=SHORT_THERMAL).log


def stacked_r(blocks):
    r = None
    for block in blocks:
        r = with_rows(r, block)
    return r


def test_stacked_r_and_least_squares_equal_numpy_on_the_whole_matrix():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(1003, 4)) * [1.0, 1e3, 1e-3, 10.0]
    y = x @ [1.0, -2.0, 3.0, 0.5] + rng.normal(size=1003)
    r = stacked_r(np.array_split(np.column_stack([x, y]), 7))
    whole = np.linalg.qr(np.column_stack([x, y]), mode="r")
    np.testing.assert_allclose(np.abs(r), np.abs(whole), rtol=1e-10, atol=1e-9)
    coefficients, rss = least_squares_from_r(r)
    expected, (expected_rss,), *_ = np.linalg.lstsq(x, y, rcond=None)
    np.testing.assert_allclose(coefficients, expected, rtol=1e-10)
    assert rss == pytest.approx(expected_rss, rel=1e-10)
    # a column repeated: the minimum-norm solution, as lstsq gives it
    twice = np.column_stack([x, x[:, :1]])
    coefficients, _ = least_squares_from_r(stacked_r(np.array_split(
        np.column_stack([twice, y]), 5)))
    np.testing.assert_allclose(coefficients, np.linalg.lstsq(twice, y, rcond=None)[0],
                               rtol=1e-8)


def test_sufficient_statistics_window_and_identifiability_do_not_depend_on_blocks(
        log, monkeypatch):
    model = DriftModel.from_terms("thermal")
    one = BenchProblem.from_log(log, model,
                                BenchOptions(noise="white", rate_window_s=RATE_WINDOW_S,
                                             errors_in_variables=False))
    window, scores = choose_rate_window(log, model, t0_C=21.0)
    monkeypatch.setattr(design, "BLOCK_ROWS", 97)  # many blocks, the last one short
    assert sum(1 for _ in model.design_blocks(log.inputs())) > 10
    many = BenchProblem.from_log(log, model,
                                 BenchOptions(noise="white", rate_window_s=RATE_WINDOW_S,
                                              errors_in_variables=False))
    for name in ("gram", "solution", "rss_min", "block_gram", "block_xr", "block_rr",
                 "block_count", "block_log_sigma"):
        np.testing.assert_allclose(
            np.asarray(getattr(many.density.sufficient_statistics(), name)),
            np.asarray(getattr(one.density.sufficient_statistics(), name)), rtol=1e-9,
            atol=1e-9, err_msg=name)
    u = jnp.asarray(np.append(np.asarray(one.density.sufficient_statistics().solution), 0.0))
    assert float(many.density.log_posterior(u)) == pytest.approx(
        float(one.density.log_posterior(u)), rel=1e-12)
    window_many, scores_many = choose_rate_window(log, model, t0_C=21.0)
    assert window_many == window
    np.testing.assert_allclose(list(scores_many.values()), list(scores.values()), rtol=1e-9)
    # A log whose temperature is held in its last block is still identified: every block
    # counts, not the last one.
    held = dict(log.columns)
    held["temperature_C"] = np.where(np.arange(log.n) < log.n - 200,
                                     held["temperature_C"], held["temperature_C"][-200])
    model.check_identifiable(BenchLog(columns=held).inputs(), {"temperature_C"})
    collinear = dict(log.columns)
    collinear["Hx_uT"] = (collinear["temperature_C"] - 21.0) * 3.0

    with pytest.raises(GyroidInputError, match="cannot be told apart"):
        DriftModel.from_terms("bias,temperature,magnetic_x").check_identifiable(
            BenchLog(columns=collinear).inputs(), {"temperature_C", "Hx_uT"})
