"""Fast paths compile once: a new log of the same shape, or another candidate model of the
same roll log, reuses the compiled code (counted from JAX's compilation log)."""

import logging

import jax
import numpy as np
import pytest
from helpers import SHORT_MAGNETIC

from gyroid.bench import BenchOptions, BenchProblem
from gyroid.inference import Emcee, problem_batcher
from gyroid.io import RollLog
from gyroid.roll import ALL_PARAMETERS, RollProblem
from gyroid.simulation import FlightProfile, simulate_flight, simulate_magnetic_bench


def _compilations(caplog, name: str) -> int:
    return sum(f"compilation of jit({name})" in r.getMessage() for r in caplog.records)


@pytest.fixture
def compile_log(caplog):
    with jax.log_compiles(True), caplog.at_level(logging.WARNING):
        yield caplog


def test_a_new_log_of_the_same_shape_reuses_the_log_posterior(compile_log):
    # A protocol length no other test uses, so the first call must compile.
    logs = [simulate_magnetic_bench(protocol=SHORT_MAGNETIC, seed=seed).log for seed in (1, 2)]
    logs = [type(log)(columns={k: v[:211] for k, v in log.columns.items()}) for log in logs]
    u = np.zeros((6, 5))
    values = []
    for log in logs:
        density = BenchProblem.from_log(log, "magnetic", BenchOptions(noise="white")).density
        values.append(np.asarray(problem_batcher(density.log_posterior)(u)))
    assert _compilations(compile_log, "batched_method") == 1
    assert not np.allclose(values[0], values[1])  # the second log's data, not the first's


def _roll_log(duration_s: float) -> RollLog:
    sim = simulate_flight(params={"D0": 0.0, "Denc": 0.0},
                          profile=FlightProfile(duration_s=duration_s), seed=5)
    return RollLog.from_columns(sim.columns)


@pytest.mark.slow
def test_roll_candidate_models_share_one_optimiser(compile_log):
    log = _roll_log(7.3)  # a length no other test uses
    fits = [RollProblem.from_log(log, terms).mode()
            for terms in ("ideal", "ideal,roll_bias", "ideal,encoder_error",
                          "ideal,roll_bias,encoder_error")]
    assert _compilations(compile_log, "_scaled_bfgs") == 1
    # D2 (a scale factor varying with |w|) takes the per-sample path: one more compilation,
    # shared again by every model with D2.
    fits += [RollProblem.from_log(log, terms).mode()
             for terms in ("ideal,sf_nonlinearity", "ideal,roll_bias,encoder_error,"
                           "sf_nonlinearity")]
    assert _compilations(compile_log, "_scaled_bfgs") == 2
    assert all(f.converged for f in fits)
    # The models really differ: the widest one has more parameters, all estimated.
    assert len(fits[-1].names) == len(fits[0].names) + 4
    assert set(fits[-1].names) <= set(ALL_PARAMETERS)


@pytest.mark.slow
def test_an_absent_roll_parameter_is_exactly_absent():
    """A model without D0 equals the wider model with D0 held at zero: the shared density's
    masked entries do not leak into the likelihood."""
    log = _roll_log(7.3)
    narrow = RollProblem.from_log(log, "ideal")
    wide = RollProblem.from_log(log, "ideal,roll_bias")
    u_narrow = np.asarray(narrow.mode().u)
    u_wide = np.insert(u_narrow, wide.names.index("D0"), 0.0)
    rows_narrow = np.asarray(narrow.density.log_likelihood_rows(u_narrow))
    rows_wide = np.asarray(wide.density.log_likelihood_rows(u_wide))
    np.testing.assert_allclose(rows_wide, rows_narrow, rtol=1e-12, atol=1e-12)


def test_an_unknown_move_is_refused_with_the_choices():
    with pytest.raises(ValueError, match="'de' or 'stretch'"):
        Emcee(move="walk").emcee_moves()


@pytest.mark.slow  # two roll densities' programs: 12 s of the quick signal, cache empty
def test_precomputed_sums_equal_the_per_sample_path():
    """Without D2 the roll likelihood reads precomputed sums of the data (cost per observed
    row); with D2 it integrates sample by sample. With D2 = 0 both must agree, on a log
    with an overloaded stabiliser (gs_rate_leak: the MEMS sums matter too)."""
    sim = simulate_flight(params={"D0": 0.02, "Denc": 0.2},
                          profile=FlightProfile(duration_s=7.3, gs_capacity_deg_s=2400.0),
                          seed=6)
    c = sim.columns
    log = RollLog.from_columns(c)
    sums = RollProblem.from_log(log, "loop")
    per_sample = RollProblem.from_log(log, "loop,sf_nonlinearity")
    assert "D1gs" in sums.names and not sums.density.full.has_d2
    u = np.asarray(sums.mode().u)
    u_wide = np.insert(u, per_sample.names.index("D2"), 0.0)
    np.testing.assert_allclose(np.asarray(per_sample.density.log_likelihood_rows(u_wide)),
                               np.asarray(sums.density.log_likelihood_rows(u)), rtol=1e-9,
                               atol=1e-9)
    np.testing.assert_allclose(np.asarray(per_sample.predict(u_wide)),
                               np.asarray(sums.predict(u)), rtol=1e-12, atol=1e-9)


def test_stabiliser_rate_sums_equal_the_per_sample_density():
    """The ideal stabiliser's MEMS samples enter through per-row counts, means and spreads:
    their total must be the sum of the per-sample normal log-densities."""
    import equinox as eqx
    from scipy import stats

    log = _roll_log(7.3)
    problem = RollProblem.from_log(log, "ideal")
    assert problem.ideal_gs
    u = np.asarray(problem.mode().u)
    full = problem.density.full
    with_mems = full.log_likelihood_rows(problem.density.spread(u))
    without = eqx.tree_at(lambda d: d.ideal_gs, full, 0.0 * full.ideal_gs)
    angle_only = without.log_likelihood_rows(problem.density.spread(u))
    values = problem.values(u)
    direct = stats.norm.logpdf(log.gs_rate_deg_s, float(values["D0gs"]),
                               float(values["sigma_m_deg_s"])).sum()
    assert float(np.sum(with_mems - angle_only)) == pytest.approx(direct, rel=1e-10)


@pytest.mark.slow
def test_logs_of_one_shape_share_the_marginal_whatever_their_step(monkeypatch):
    """Two thermal logs of as many block means, one sampled at twice the other's rate over
    half the time: their steps, a row's white scale and the flicker's variances differ, and
    are arrays of the marginal's programs, not constants compiled into them (the second
    log's programs are the first's, by their keys in gyroid's program store)."""
    import gyroid._exported as store
    from gyroid.simulation import ThermalProtocol, simulate_thermal_bench

    marginal = ("_batched_bfgs", "marginal_gradients", "conditional_solution")
    keys: list[set[str]] = []
    keyed = store.program_key

    def recorded(name: str, args: tuple):
        found = keyed(name, args)
        if found is not None and name.endswith(marginal):
            keys[-1].add(found[0])
        return found

    monkeypatch.setattr(store, "program_key", recorded)
    options = BenchOptions(errors_in_variables=False)  # the noise alone: IEEE 952's
    steps, modes = [], []
    for hours, rate_hz in ((0.7, 1.0), (1.4, 0.5)):  # 2520 samples: 840 means of three
        keys.append(set())
        protocol = ThermalProtocol().stretched(hours=hours, rate_hz=rate_hz)
        problem = BenchProblem.from_log(simulate_thermal_bench(protocol=protocol, seed=3).log,
                                        "thermal", options)
        steps.append(problem.density.step_s)
        modes.append(problem.mode())
    assert steps[1] == 2 * steps[0]
    assert len(keys[0]) >= 2 and keys[1] <= keys[0]
    assert all(m.converged for m in modes)
