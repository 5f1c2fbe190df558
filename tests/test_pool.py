"""Pooling runs of one gyro type (issue 17, contract ``gyroid pool``): the marginal
likelihood against brute-force Gaussian algebra, recovery on simulated lots, the lot's
checks, the CLI and compensation with a new-run predictive, paper A's table."""

import json
import math

import numpy as np
import pytest
from helpers import SHORT_MAGNETIC
from scipy.stats import multivariate_normal

from gyroid.bench import BenchOptions
from gyroid.cli import main
from gyroid.errors import GyroidInputError
from gyroid.io import run_labels
from gyroid.models import LogNormal, Normal
from gyroid.papers import magnetic_repeatability, repeatability_json
from gyroid.pipeline._compensate_file import fitted_axes
from gyroid.pool import PoolProblem, fit_pool
from gyroid.simulation import simulate_lot


def _small_lot(seed: int = 1):
    """Three runs' estimates of a 3-coefficient model with correlated errors of known
    covariance (one run hardly measures coefficient 2), and the Gaussian algebra to check
    against."""
    rng = np.random.default_rng(seed)
    r, p = 3, 3
    mu, tau = np.array([1.0, -0.5, 0.3]), np.array([0.4, 0.2, 0.7])
    covariances = []
    for _ in range(r):
        root = rng.normal(size=(p, p)) * 0.3
        covariances.append(root @ root.T + 0.05 * np.eye(p))
    covariances[2][2, 2] += 400.0  # a run that does not exercise coefficient 2
    estimates = np.array([mu + tau * rng.normal(size=p) + rng.multivariate_normal(
        np.zeros(p), c) for c in covariances])
    prior = Normal(0.2, 2.0)
    problem = PoolProblem.from_estimates(
        ("a", "b", "c"), ("r0", "r1", "r2"), estimates, np.array(covariances),
        mean_priors=[prior] * p, spread_scales=[1.0] * p, own_mean=estimates,
        own_sd=np.sqrt(np.array([np.diag(c) for c in covariances])), reference=np.ones(p))
    return problem, estimates, np.array(covariances), tau, prior


def test_run_likelihood_given_the_population_is_the_exact_gaussian_marginal():
    problem, estimates, covariances, tau, _ = _small_lot()
    mu = np.array([1.1, -0.4, 0.4])
    ours = np.asarray(problem.density.run_log_likelihood(mu, np.log(tau)))
    exact = [multivariate_normal(mu, c + np.diag(tau**2)).logpdf(e)
             for e, c in zip(estimates, covariances, strict=True)]
    np.testing.assert_allclose(ours, exact, rtol=1e-10, atol=1e-10)
    # a run taken out holds no information: its log-likelihood is 0 at every mu
    assert float(problem.without_run(1).density.run_log_likelihood(mu, np.log(tau))[1]) == (
        pytest.approx(0.0, abs=1e-12))


def test_population_mean_integrates_out_exactly_and_its_conditional_is_exact():
    problem, estimates, covariances, tau, prior = _small_lot()
    u = np.log(tau)
    # All runs jointly: estimate_r = mu + (theta_r - mu) + error_r, mu ~ N(loc, scale^2 I).
    p = 3
    stacked = np.tile(np.eye(p), (3, 1))
    noise_cov = np.zeros((3 * p, 3 * p))
    for r, c in enumerate(covariances):
        noise_cov[r * p:(r + 1) * p, r * p:(r + 1) * p] = c + np.diag(tau**2)
    prior_cov = prior.scale**2 * np.eye(p)
    loc = np.full(p, prior.loc)
    joint = noise_cov + stacked @ prior_cov @ stacked.T
    y_all = estimates.ravel()
    exact = multivariate_normal(stacked @ loc, joint).logpdf(y_all)
    ours = float(problem.density.log_likelihood_mean_free(u))
    assert ours == pytest.approx(exact, abs=1e-9)
    # The conditional mean of mu given the estimates (Gaussian conditioning, by hand).
    gain = prior_cov @ stacked.T @ np.linalg.inv(joint)
    expected = loc + gain @ (y_all - stacked @ loc)
    ours = np.asarray(problem.density.mean_conditional(u, np.zeros(p)))
    np.testing.assert_allclose(ours, expected, rtol=1e-9, atol=1e-9)


@pytest.mark.slow
def test_pooled_lot_recovers_the_population_and_its_spread():
    lot = simulate_lot("magnetic", 8, seed=4, spread=0.2, hours=SHORT_MAGNETIC.duration_s / 3600)
    # the simulator's noise is white: the exact white pool is the right model
    result = fit_pool([r.log for r in lot.runs], lot.labels, "magnetic",
                      BenchOptions(noise="white"), seed=2)
    record = result.to_json()
    assert result.trustworthy, result.checks.lines()
    for name, truth in lot.population_mean.items():
        post = record["population"][name]
        # 4 posterior sd: a miss has probability 6e-5 per coefficient when calibrated.
        assert abs(post["mean"] - truth) < 4 * post["sd"], (name, post, truth)
        spread = record["between_run_sd"][name]
        assert spread["ci95"][0] < lot.between_run_sd[name] < spread["ci95"][1] * 1.5
    # The runs' pooled coefficients are their own estimates pulled towards the population
    # (per run a correlated coefficient may move out a little; summed over runs, in).
    mean = result.mean_draws.reshape(-1, 4).mean(axis=0)
    pooled = result.run_draws.mean(axis=0)
    assert np.all(np.abs(pooled - mean).sum(axis=0) < np.abs(result.own_mean - mean).sum(axis=0))
    # The new-run predictive is wider than the population mean's interval.
    for name in lot.population_mean:
        assert record["new_run_predictive"][name]["sd"] > record["population"][name]["sd"]


@pytest.mark.slow
def test_a_run_from_another_population_is_named():
    lot = simulate_lot("magnetic", 6, seed=5, spread=0.1, hours=SHORT_MAGNETIC.duration_s / 3600)
    logs = [r.log for r in lot.runs]
    from gyroid.simulation import simulate_magnetic_bench

    odd = dict(lot.runs[0].truth["parameters"])
    odd["wy"] = lot.population_mean["wy"] + 3.0  # 50 between-run sds away
    logs[3] = simulate_magnetic_bench(parameters=odd, protocol=SHORT_MAGNETIC, seed=77).log
    # white runs
    result = fit_pool(logs, lot.labels, "magnetic", BenchOptions(noise="white"), seed=0)
    check = next(c for c in result.checks.checks if c.name == "run_consistency")
    assert not check.passed and check.severity == "error"
    assert "run_04" in check.message
    assert not result.trustworthy


def test_pool_refuses_what_it_cannot_pool():
    lot = simulate_lot("magnetic", 2, seed=6, hours=0.3)
    logs = [r.log for r in lot.runs]
    with pytest.raises(GyroidInputError, match="at least two logs"):
        fit_pool(logs[:1], lot.labels[:1], "magnetic")
    with pytest.raises(GyroidInputError, match="warmup"):
        fit_pool(logs, lot.labels, "magnetic,warmup")
    with pytest.raises(GyroidInputError, match="same name"):
        fit_pool(logs, ("a", "a"), "magnetic")
    # a misspelt option is named before any run is fitted (under the default noise each
    # run's own fit comes first)
    with pytest.raises(GyroidInputError, match="no coefficient named 'wq'"):
        fit_pool(logs, lot.labels, "magnetic", priors={"wq": Normal(0.0, 1.0)})
    with pytest.raises(GyroidInputError, match="between-run sd scale of 'w0'"):
        fit_pool(logs, lot.labels, "magnetic", spread_scales={"w0": -1.0})
    with pytest.raises(GyroidInputError, match="a population mean takes normal"):
        fit_pool(logs, lot.labels, "magnetic", priors={"w0": LogNormal(1.0, 0.5)})


def test_run_labels_from_paths(tmp_path):
    assert run_labels(["a/run1.csv", "b/run2.csv.gz"]) == ("run1", "run2")
    assert run_labels(["lot/run_01/bench.csv", "lot/run_02/bench.csv"]) == ("run_01", "run_02")
    assert run_labels(["x/a/bench.csv", "y/a/log.csv"]) == ("bench", "log")
    with pytest.raises(GyroidInputError, match="same name"):
        run_labels(["x/a/bench.csv", "y/a/bench.csv"])


@pytest.mark.slow
def test_cli_pool_and_compensation_with_the_new_run_predictive(tmp_path, capsys):
    lot_dir, pool_dir = tmp_path / "lot", tmp_path / "pool"
    assert main(["simulate", "magnetic", "--runs", "4", "--hours", "0.5", "--out",
                 str(lot_dir), "--seed", "3"]) == 0
    truth = json.loads((lot_dir / "lot.json").read_text())
    assert truth["runs"] == ["run_01", "run_02", "run_03", "run_04"]
    logs = [str(lot_dir / r / "bench.csv") for r in truth["runs"]]
    capsys.readouterr()
    code = main(["pool", *logs, "--terms", "magnetic", "--out", str(pool_dir), "--seed", "1"])
    assert "run_02 fitted (2 of 4)" in capsys.readouterr().err  # each run's fit is heard of
    record = json.loads((pool_dir / "pool.json").read_text())
    assert code == (0 if record["trustworthy"] else 3)
    for key in ("terms", "runs", "population", "between_run_sd", "per_run",
                "new_run_predictive", "checks", "trustworthy"):
        assert key in record
    assert record["runs"] == truth["runs"]
    assert set(record["per_run"]["run_02"]) == {"w0", "wx", "wy", "wz"}
    for entry in record["population"].values():
        assert set(entry) >= {"mean", "sd", "ci95"}
    assert (pool_dir / "forest.png").exists() and (pool_dir / "posterior.nc").exists()
    # A new unit compensated with the pool: its model sd is the new-run predictive's.
    assert main(["simulate", "magnetic", "--hours", "0.5", "--out", str(tmp_path / "new"),
                 "--seed", "9"]) == 0
    out = tmp_path / "comp"
    main(["compensate", str(tmp_path / "new" / "bench.csv"), "--fit", str(pool_dir), "--out",
          str(out)])
    comp = json.loads((out / "compensate.json").read_text())
    assert comp["model_source"] == "pool: predictive for a new run"
    rows = np.genfromtxt(out / "compensated.csv", delimiter=",", names=True)
    # At zero field the modelled drift is w0: its sd is that of the new-run predictive's
    # draws compensation used (400 of them, chosen by its seed, 0). Not the pool's sd of
    # all its draws: with four runs the predictive is heavy-tailed, and 400 draws' sd
    # strayed 25 % from it on one machine's numerics.
    fitted = fitted_axes(pool_dir)[None]
    draws = fitted.draws[np.random.default_rng(0).choice(fitted.draws.shape[0], 400,
                                                         replace=False)]
    w0_sd = np.std(draws[:, fitted.model.parameter_names.index("w0")])
    assert w0_sd == pytest.approx(record["new_run_predictive"]["w0"]["sd"], rel=0.5)
    quiet = np.abs(rows["Hx_uT"]) + np.abs(rows["Hy_uT"]) + np.abs(rows["Hz_uT"]) < 1.0
    # less than 1 uT of 50 adds at most a few per cent of the field terms' spread
    assert np.median(rows["drift_model_sd_deg_h"][quiet]) == pytest.approx(w0_sd, rel=0.03)


@pytest.mark.slow
def test_paper_a_table_test_to_test_spread():
    pools = magnetic_repeatability(seed=0)
    record = repeatability_json(pools)
    s = record["assumed_within_test_sd"]
    assert s == pytest.approx(math.sqrt(2) * 0.005 * 60 / math.sqrt(180) / 6)
    device2 = record["devices"]["device 2"]["axes"]
    # wy: -0.576 vs -0.375 is 27 sd of a difference apart: real test-to-test variation.
    assert device2["wy"]["p_value"] < 1e-10
    assert device2["wy"]["s_star"] == pytest.approx(0.201 / (1.959964 * math.sqrt(2)), rel=1e-6)
    assert "real test-to-test variation" in device2["wy"]["verdict"]
    # wx: -0.037 vs -0.043 is within the noise.
    assert device2["wx"]["p_value"] > 0.05 and "within the noise" in device2["wx"]["verdict"]
    # Two tests cannot pin down a between-test sd: the lot check says so.
    checks = record["devices"]["device 2"]["checks"]
    assert not checks["between_run_sd_identified"]["passed"]


@pytest.mark.slow
def test_pooled_intervals_cover_at_the_nominal_rate():
    """SBC in small (experiments/pool_sbc.py runs 100 lots of 3, 8 and 30 runs): truth
    from the priors the fit uses, lots of four short sweeps; the 90 % intervals of the
    population means and between-run sds must cover within the binomial 99.9 % band. The
    lots' noise is white, and pooled as such (``noise="white"``): the exact algebra's
    calibration; the default pool fits each run under IEEE noise first."""
    from scipy import stats

    from gyroid.simulation import simulate_magnetic_bench

    priors = {"w0": Normal(1.0, 0.5), "wx": Normal(0.0, 0.3), "wy": Normal(-0.3, 0.3),
              "wz": Normal(0.0, 0.3)}
    scales = {"w0": 0.3, "wx": 0.05, "wy": 0.1, "wz": 0.05}
    rng = np.random.default_rng(11)
    hits = {"mean": [], "between_sd": []}
    for dataset in range(25):
        mean = {n: rng.normal(p.loc, p.scale) for n, p in priors.items()}
        spread = {n: abs(rng.normal(0.0, s)) for n, s in scales.items()}
        logs = [simulate_magnetic_bench(
            parameters={n: mean[n] + spread[n] * rng.standard_normal() for n in priors},
            protocol=SHORT_MAGNETIC, seed=int(rng.integers(2**31))).log for _ in range(4)]
        result = fit_pool(logs, ("a", "b", "c", "d"), "magnetic", BenchOptions(noise="white"),
                          seed=dataset, priors=priors, spread_scales=scales)
        tau = result.posterior.draws.reshape(-1, result.posterior.draws.shape[-1])
        for k, n in enumerate(priors):
            for kind, truth, draws in (("mean", mean[n], result.mean_draws[..., k].ravel()),
                                       ("between_sd", spread[n], tau[:, k])):
                lo, hi = np.quantile(draws, [0.05, 0.95])
                hits[kind].append(lo <= truth <= hi)
    for kind, values in hits.items():
        band = stats.binom.ppf([0.0005, 0.9995], len(values), 0.9)
        assert band[0] <= sum(values) <= band[1], (kind, sum(values), len(values), band)
