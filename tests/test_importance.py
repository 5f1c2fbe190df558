"""Pareto-smoothed importance sampling of a collapsed problem (gyroid.inference.Importance)
against the exact posterior, computed here by quadrature on a grid of the noise levels."""

import itertools

import equinox as eqx
import jax
import numpy as np
import pytest
from helpers import SHORT_THERMAL

from gyroid import BenchLog, GyroNoise
from gyroid.bench import BenchOptions, BenchProblem
from gyroid.inference import Emcee, Importance
from gyroid.inference._batching import in_chunks, problem_batcher
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.simulation import simulate_thermal_bench

_EXACT = {}


def _exact(problem, point):
    """The quadrature, once per module."""
    if "value" not in _EXACT:
        _EXACT["value"] = _quadrature(problem, point)
    return _EXACT["value"]


@pytest.fixture(scope="module")
def walked_problem():
    """A 20-minute log at 1 Hz whose bias walks, fitted with a temperature slope under IEEE
    952 noise: three noise levels, two coefficients integrated out. Its posterior is not
    the mode's Gaussian: B keeps its prior's lower tail against a cliff, and 42 % of log K's
    mass lies in its prior's tail (the flicker explaining the wander instead), a part that
    emcee started at the mode missed on two seeds of three."""
    rng = np.random.default_rng(5)
    n = 1200
    temperature = np.linspace(15.0, 35.0, n)
    drift = (0.8 + 0.05 * (temperature - 21.0) + np.cumsum(rng.normal(0.0, 0.01, n))
             + rng.normal(0.0, 0.2, n))
    log = BenchLog(columns={"time_s": np.arange(n, dtype=float), "temperature_C": temperature,
                            "drift_deg_h": drift})
    problem = BenchProblem.from_log(log, "bias,temperature", BenchOptions(noise="white+flicker+rw"))
    return problem, problem.mode()


def _quadrature(problem, point):
    """The exact posterior's means and sds of every sampling coordinate: the collapsed
    marginal of the noise levels summed over a grid of the log levels, each node carrying
    the coefficients' exact conditional Gaussian (the law of total variance). The white
    level is resolved (1 sd apart within 8 of the mode's); flicker and walk span their
    priors' +/- 4.5 sds 0.3 apart, fine enough for either level's bump (sds 0.14 and more)
    wherever it sits: the posterior has one where the walk explains the wander and another
    where the flicker does."""
    collapsed = problem.collapsed()
    k = int(collapsed.noise_loc.size)
    p = point.u.size - k
    white = np.asarray(point.u)[p] + np.linspace(-8.0, 8.0, 17) * np.sqrt(
        np.asarray(point.covariance_u)[p, p])
    axes = [white] + [float(collapsed.noise_loc[a]) + np.arange(-13.5, 13.51, 0.3)
                      for a in (1, 2)]
    nodes = np.array(list(itertools.product(*axes)))
    log_post = in_chunks(problem_batcher(collapsed.log_posterior), nodes, 1024)
    w = np.exp(log_post - log_post.max())
    w /= w.sum()
    cube = w.reshape([x.size for x in axes])
    for a in range(k):  # the box holds the mass: little of it on any face
        assert np.take(cube, [0, -1], axis=a).sum() < 1e-4
    live = w > 1e-12 * w.max()  # the conditional Gaussians where the weight is not nil
    w, nodes = w[live] / w[live].sum(), nodes[live]
    mean_beta, var_beta = [], []
    for start in range(0, nodes.shape[0], 1024):
        mean_b, factor = _solved(collapsed, nodes[start:start + 1024])
        mean_beta.append(np.asarray(mean_b))
        precision = np.asarray(factor) @ np.swapaxes(np.asarray(factor), 1, 2)
        var_beta.append(np.diagonal(np.linalg.inv(precision), axis1=1, axis2=2))
    mean_beta, var_beta = np.concatenate(mean_beta), np.concatenate(var_beta)
    mean = np.concatenate([w @ mean_beta, w @ nodes])
    second = np.concatenate([w @ (var_beta + mean_beta**2), w @ nodes**2])
    return mean, np.sqrt(second - mean**2)


@eqx.filter_jit
def _solved(collapsed, nodes):
    """The coefficients' conditional mean and precision factor at each node."""
    return jax.vmap(lambda v: collapsed._solve(v)[:2])(nodes)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 4, 5])
def test_importance_sampling_reaches_the_exact_posterior(walked_problem, seed):
    """Every sampling coordinate's mean within 4.5 Monte-Carlo standard errors of the
    quadrature's (sd / sqrt(ESS)), its sd within 4.5 of the sd's; the Pareto k says the
    weights are reliable; the same seed gives the same draws. (A first stage without the
    prior-tail parts, or far too narrow, can miss the walk's tail and still report a
    small k: importance sampling is as good as what its first stage reaches.)"""
    problem, point = walked_problem
    exact_mean, exact_sd = _exact(problem, point)
    assert exact_sd[-1] > 2.0  # log K reaches into its prior's tail (its bump's sd: 0.14)
    posterior = Importance().sample(problem, point, seed=seed)
    assert posterior.move == "psis" and "Pareto k" in posterior.method, posterior.method
    u = problem.to_sampling_host(posterior.draws).reshape(-1, len(problem.names))
    for i, name in enumerate(problem.names):
        ess = posterior.summary[name]["ess_bulk"]
        assert ess >= 400, name
        se = exact_sd[i] / np.sqrt(ess)
        assert abs(u[:, i].mean() - exact_mean[i]) < 4.5 * se, name
        # a sample sd's standard error, sd sqrt((kurtosis - 1) / 4n): these marginals are
        # mixtures of the two parts' (heavier-tailed than a Gaussian's kurtosis of 3)
        kurtosis = np.mean((u[:, i] - u[:, i].mean()) ** 4) / u[:, i].var() ** 2
        se_sd = exact_sd[i] * np.sqrt((kurtosis - 1.0) / (4.0 * ess))
        assert abs(u[:, i].std() - exact_sd[i]) < 4.5 * se_sd, name
    again = Importance().sample(problem, point, seed=seed)
    np.testing.assert_array_equal(again.draws, posterior.draws)


@pytest.mark.slow
def test_kept_draws_carry_the_joint_log_posterior(walked_problem):
    """The kept draws' log-posterior, the marginal's plus the conditional Gaussian's
    (no further filter pass), is the joint density's own at every draw; and the
    coefficients given the levels are the exact conditional's draws (standardised by it,
    each draw by its own levels, standard normal)."""
    problem, point = walked_problem
    posterior = Importance().sample(problem, point, seed=7)
    u = problem.to_sampling_host(posterior.draws).reshape(-1, len(problem.names))
    joint = in_chunks(problem_batcher(problem.density.log_posterior), u, 250)
    np.testing.assert_allclose(posterior.log_posterior.reshape(-1), joint, rtol=0, atol=1e-7)
    p = problem.n_model
    mean, factor = (np.asarray(a) for a in _solved(problem.collapsed(), u[:, p:]))
    # P^(1/2)' (beta - beta_hat(v)) per draw: independent standard normals
    z = np.einsum("nji,nj->ni", factor, u[:, :p] - mean)
    n = z.shape[0]
    assert np.all(np.abs(z.mean(axis=0)) < 4.5 / np.sqrt(n)), z.mean(axis=0)
    assert np.all(np.abs(z.var(axis=0) - 1.0) < 4.5 * np.sqrt(2.0 / n)), z.var(axis=0)


@pytest.mark.slow
def test_unreliable_weights_go_to_emcee(walked_problem):
    """A proposal a thousandth of the mode's covariance misses the posterior's bulk: its
    Pareto k is far above 0.7, and the fallback (emcee, cut short here: on this posterior,
    a prior's tail against a cliff, it needs some 400 steps per autocorrelation time)
    samples instead, as it says."""
    problem, point = walked_problem
    short = Emcee(progress=False, burn_steps=100, chunk_steps=100, max_steps=200)
    posterior = Importance(inflation=(1e-3,), stages=1, fallback=short).sample(problem, point,
                                                                            seed=1)
    assert posterior.method.startswith("emcee") and posterior.move == "de"
    assert posterior.n_steps == 200


def test_white_noise_integrates_the_coefficients_out_on_sufficient_statistics():
    """White noise of unknown level: the coefficients integrate out on the rows' sufficient
    statistics, and importance sampling weighs the level alone. A constant bias under white
    noise and weak priors: w0's posterior is Student's t about the rows' mean, sd
    s / sqrt(n) * sqrt((n - 1) / (n - 3)) (s the rows' sd), to within 4 Monte-Carlo
    standard errors."""
    rng = np.random.default_rng(2)
    drift = 1.0 + rng.normal(0.0, 0.3, 300)
    log = BenchLog(columns={"time_s": np.arange(300.0), "drift_deg_h": drift})
    problem = BenchProblem.from_log(log, "bias", BenchOptions(noise="white"))
    posterior = Importance().sample(problem, problem.mode(), seed=0)
    assert posterior.move == "psis" and "of the noise level (" in posterior.method
    w0 = posterior.summary["w0"]
    n = drift.size
    sd = drift.std(ddof=1) / np.sqrt(n) * np.sqrt((n - 1) / (n - 3))
    assert abs(w0["mean"] - drift.mean()) < 4 * sd / np.sqrt(w0["ess_bulk"])
    assert abs(w0["sd"] / sd - 1) < 4 / np.sqrt(2 * w0["ess_bulk"])


@pytest.mark.parametrize("sigma_given", [False, True])
def test_the_white_marginal_and_conditional_are_the_joint_density(sigma_given):
    """The white rows' marginal (:class:`SufficientCoefficients`) and the coefficients'
    conditional Gaussian multiply to the joint posterior density at any point, with the
    level sampled or each row's sd given; a log that gives each row's sd leaves no level
    to weigh, and its coefficients are drawn from their Gaussian posterior directly (its
    mean within 4 Monte-Carlo standard errors of the closed-form mode's)."""
    from gyroid.inference._collapsed import SufficientCoefficients, collapse, conditional_draws

    rng = np.random.default_rng(3)
    n = 400
    time_s = np.arange(n, dtype=float)
    temperature = 20.0 + 10.0 * np.sin(time_s / 80.0)
    columns = {"time_s": time_s, "temperature_C": temperature,
               "drift_deg_h": 0.5 + 0.02 * temperature + rng.normal(0.0, 0.1, n)}
    if sigma_given:
        columns["sigma_deg_h"] = rng.uniform(0.05, 0.2, n)
    problem = BenchProblem.from_log(BenchLog(columns=columns), "bias,temperature",
                                    BenchOptions(noise="white", errors_in_variables=False))
    form = collapse(problem.density)
    assert isinstance(form, SufficientCoefficients)
    point, p = problem.mode(), problem.n_model
    for _ in range(4):
        u = point.u + 3.0 * rng.standard_normal(point.u.size) * np.sqrt(
            np.diag(point.covariance_u))
        row = np.asarray(form.solved(u[p:]))
        factor = row[1 + p:].reshape(p, p)
        z = factor.T @ (u[:p] - row[1:1 + p])
        joint = float(problem.density.log_posterior(u))
        np.testing.assert_allclose(conditional_draws(row[None], z[None])[1][0], joint,
                                   rtol=1e-12, atol=1e-9)
    target = problem.marginal_target()
    assert target.marginal.size == (0 if sigma_given else 1) and target.real.size == p
    posterior = Importance().sample(problem, point, seed=1)
    if sigma_given:  # nothing to weigh: independent draws of the coefficients' Gaussian
        assert posterior.method.startswith("exact draws")
        n_draws = posterior.draws[..., 0].size
        for name in problem.names:
            error = posterior.summary[name]["mean"] - point.value[name]
            assert abs(error) < 4 * point.sd[name] / np.sqrt(n_draws), name


@pytest.mark.slow
def test_stored_block_log_likelihoods_need_one_filter_pass_per_noise_level(walked_problem):
    """posterior.nc's block log-likelihoods of an importance posterior, computed with one
    filter pass per distinct noise level (its draws repeat them) and the filter's linearity,
    equal the density's own ``log_likelihood_blocks`` at every draw."""
    from gyroid.inference._storage import block_log_likelihood

    problem, point = walked_problem
    posterior = Importance().sample(problem, point, seed=3)
    fast = block_log_likelihood(problem, posterior)
    flat = np.asarray(problem.to_sampling_host(
        posterior.draws.reshape(-1, posterior.draws.shape[-1])))
    levels = np.unique(flat[:, problem.n_model:], axis=0).shape[0]
    assert levels < flat.shape[0]  # the saving: repeated levels
    direct = in_chunks(problem_batcher(problem.density.log_likelihood_blocks), flat, 256)
    np.testing.assert_allclose(fast.reshape(direct.shape), direct, rtol=1e-9, atol=1e-9)


def test_stored_block_log_likelihoods_of_rows_with_the_thermometers_covariance():
    """Under white noise carrying the thermometer, the marginal's innovations are the
    coordinates of the rows' covariance's eigenbasis, not rows in time order: the stored
    blocks are still the rows' own (each row given every other), the density's
    ``log_likelihood_blocks`` at every draw, and they sum to its log-likelihood."""
    from gyroid.inference._storage import block_log_likelihood

    sim = simulate_thermal_bench(protocol=SHORT_THERMAL, seed=5,
                                 noise=GyroNoise(temperature_noise_C=0.05))
    problem = BenchProblem.from_log(sim.log, "thermal",
                                    BenchOptions(noise="white", rate_window_s=RATE_WINDOW_S),
                                    max_rows=200)
    assert problem.noise.carried is not None
    posterior = Importance().sample(problem, problem.mode(), seed=3)
    fast = block_log_likelihood(problem, posterior)
    flat = np.asarray(problem.to_sampling_host(
        posterior.draws.reshape(-1, posterior.draws.shape[-1])))
    direct = in_chunks(problem_batcher(problem.density.log_likelihood_blocks), flat, 256)
    np.testing.assert_allclose(fast.reshape(direct.shape), direct, rtol=1e-9, atol=1e-9)


@pytest.mark.slow
def test_a_time_constant_is_sampled_as_its_exact_marginal():
    """A warm-up (2 deg/h, 400 s, on 50 min) under white + Gauss-Markov noise: importance
    sampling draws the time constant with the noise levels
    (:mod:`gyroid.inference._marginal_target`), the coefficients exactly given both. With
    the levels pinned by their priors (log-sds of 1e-3), the time constant's posterior is
    one-dimensional, and quadrature on a grid of it (each node carrying the coefficients'
    exact conditional Gaussian) gives the means and sds the draws must match within 4.5
    Monte-Carlo standard errors; each kept draw's log-posterior is the joint density's
    own."""
    from gyroid.bench._point_profiled import _Profile
    from gyroid.inference._collapsed import conditional_solution, padded
    from gyroid.models import LogNormal

    rng = np.random.default_rng(11)
    n, tau_s, a = 3000, 400.0, np.exp(-1.0 / 100.0)
    wander = np.zeros(n)
    for i in range(1, n):  # a Gauss-Markov bias: 0.05 deg/h, 100 s
        wander[i] = a * wander[i - 1] + rng.normal(0.0, 0.05 * np.sqrt(1 - a**2))
    time_s = np.arange(n, dtype=float)
    drift = 0.5 + 2.0 * np.exp(-time_s / tau_s) + wander + rng.normal(0.0, 0.3, n)
    log = BenchLog(columns={"time_s": time_s, "drift_deg_h": drift})
    pinned = {"sigma_deg_h": LogNormal(0.3, 1e-3), "sigma_gm_deg_h": LogNormal(0.05, 1e-3),
              "tau_gm_s": LogNormal(100.0, 1e-3)}
    problem = BenchProblem.from_log(log, "bias,warmup",
                                    BenchOptions(noise="white+gm", priors=pinned))
    point = problem.mode()
    posterior = Importance().sample(problem, point, seed=4)
    assert posterior.move == "psis" and "positive parameter" in posterior.method
    u = problem.to_sampling_host(posterior.draws).reshape(-1, len(problem.names))
    joint = in_chunks(problem_batcher(problem.density.log_posterior), u, 250)
    np.testing.assert_allclose(posterior.log_posterior.reshape(-1), joint, rtol=0, atol=1e-7)

    names = list(problem.names)
    tau, w = names.index("tau_warmup_min"), names.index("w_warmup")
    profile = _Profile(problem.density)
    v = point.u[problem.n_model:]
    centre, spread = point.u[tau], np.sqrt(point.covariance_u[tau, tau])
    nodes = np.linspace(centre - 10 * spread, centre + 6.0, 2001)  # a long upper tail
    log_post = profile.values(nodes[:, None], v)
    weight = np.exp(log_post - log_post.max())
    weight /= weight.sum()
    assert weight[0] + weight[-1] < 1e-8, (weight[0], weight[-1])  # the grid holds the mass
    real = [i for i, name in enumerate(names[:problem.n_model]) if name != "tau_warmup_min"]
    k = real.index(w)
    mean_w, var_w = [], []
    for node in nodes:
        mean, factor = conditional_solution(padded(profile.at(np.array([node]))), v)
        factor = np.asarray(factor)
        mean_w.append(float(np.asarray(mean)[k]))
        var_w.append(float(np.linalg.inv(factor @ factor.T)[k, k]))
    mean_w, var_w = np.array(mean_w), np.array(var_w)
    exact = {tau: (weight @ nodes, np.sqrt(weight @ nodes**2 - (weight @ nodes) ** 2)),
             w: (weight @ mean_w,
                 np.sqrt(weight @ (var_w + mean_w**2) - (weight @ mean_w) ** 2))}
    for i, (mean, sd) in exact.items():
        ess = posterior.summary[names[i]]["ess_bulk"]
        assert ess >= 400, names[i]
        assert abs(u[:, i].mean() - mean) < 4.5 * sd / np.sqrt(ess), names[i]
        # a sample sd's standard error, sd sqrt((kurtosis - 1) / 4n): w_warmup's marginal
        # is a mixture over the time constant, heavier-tailed than a Gaussian
        kurtosis = np.mean((u[:, i] - u[:, i].mean()) ** 4) / u[:, i].var() ** 2
        se_sd = sd * np.sqrt((kurtosis - 1.0) / (4.0 * ess))
        assert abs(u[:, i].std() - sd) < 4.5 * se_sd, (names[i], u[:, i].std(), sd, kurtosis)
