"""Pareto-smoothed importance sampling of a collapsed problem (gyroid.inference.Importance)
against the exact posterior, computed here by quadrature on a grid of the noise levels."""

import itertools
import re

import equinox as eqx
import jax
import numpy as np
import pytest

from gyroid import BenchLog
from gyroid.inference import BenchProblem, Emcee, Importance
from gyroid.inference._batching import in_chunks, problem_batcher

_EXACT = {}


def _exact(problem, point):
    """The quadrature, once per module."""
    if "value" not in _EXACT:
        _EXACT["value"] = _quadrature(problem, point)
    return _EXACT["value"]


@pytest.fixture(scope="module")
def walked_problem():
    """A 20-minute log at 1 Hz whose bias walks, fitted with a temperature slope under IEEE
    952 noise: three noise levels, two coefficients integrated out."""
    rng = np.random.default_rng(5)
    n = 1200
    temperature = np.linspace(15.0, 35.0, n)
    drift = (0.8 + 0.05 * (temperature - 21.0) + np.cumsum(rng.normal(0.0, 0.01, n))
             + rng.normal(0.0, 0.2, n))
    log = BenchLog(columns={"time_s": np.arange(n, dtype=float), "temperature_C": temperature,
                            "drift_deg_h": drift})
    problem = BenchProblem.from_log(log, "bias,temperature", noise="white+flicker+rw")
    return problem, problem.mode()


def _quadrature(problem, point, per_axis=31, drop=40.0):
    """The exact posterior's means and sds of every sampling coordinate: the collapsed
    marginal of the noise levels summed over a box of the log levels (each axis as far as a
    slice through the mode falls ``drop`` below its peak: the posterior need not look like
    the mode's Gaussian, e.g. a level the log does not resolve keeps its prior's lower tail
    and meets a cliff above), each node carrying the coefficients' exact conditional
    Gaussian (the law of total variance)."""
    collapsed = problem.collapsed()
    batch = problem_batcher(collapsed.log_posterior)
    k = int(collapsed.noise_loc.size)
    d = point.u.size
    p = d - k
    centre = np.asarray(point.u)[p:]
    sd = np.sqrt(np.diag(np.asarray(point.covariance_u))[p:])
    axes = []
    for a in range(k):
        reach = np.linspace(-15.0, 15.0, 121) * sd[a]
        line = np.tile(centre, (reach.size, 1))
        line[:, a] += reach
        lp = np.asarray(batch(line))
        inside = reach[lp > lp.max() - drop]
        axes.append(centre[a] + np.linspace(inside.min() - sd[a], inside.max() + sd[a],
                                            per_axis))
    nodes = np.array(list(itertools.product(*axes)))
    log_post = in_chunks(batch, nodes, 512)
    w = np.exp(log_post - log_post.max())
    w /= w.sum()
    cube = w.reshape((per_axis,) * k)
    for a in range(k):  # the box holds the mass: little of it on any face
        assert np.take(cube, [0, -1], axis=a).sum() < 1e-4
    mean_beta, var_beta = [], []
    for start in range(0, nodes.shape[0], 512):
        mean_b, factor = _solved(collapsed, nodes[start:start + 512])
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
@pytest.mark.parametrize(("sampler", "stages"), [
    (Importance(), {1}),
    # a first stage far too narrow (a tenth of the mode's covariance): the adapted stages
    # must find the posterior's tails themselves
    (Importance(inflation=(0.1,)), {2, 3, 4}),
])
def test_importance_sampling_reaches_the_exact_posterior(walked_problem, sampler, stages):
    """Every sampling coordinate's mean within 4.5 Monte-Carlo standard errors of the
    quadrature's (sd / sqrt(ESS)), its sd within 4.5 of the sd's (about sd / sqrt(2 ESS));
    the Pareto k says the weights are reliable; the same seed gives the same draws."""
    problem, point = walked_problem
    exact_mean, exact_sd = _exact(problem, point)
    posterior = sampler.sample(problem, point, seed=3)
    assert posterior.move == "psis" and "Pareto k" in posterior.method, posterior.method
    assert int(re.search(r"in (\d+) stage", posterior.method).group(1)) in stages
    u = problem.to_sampling_host(posterior.draws).reshape(-1, len(problem.names))
    for i, name in enumerate(problem.names):
        ess = posterior.summary[name]["ess_bulk"]
        assert ess >= 400, name
        se = exact_sd[i] / np.sqrt(ess)
        assert abs(u[:, i].mean() - exact_mean[i]) < 4.5 * se, name
        assert abs(u[:, i].std() - exact_sd[i]) < 4.5 * exact_sd[i] / np.sqrt(2.0 * ess), name
    again = sampler.sample(problem, point, seed=3)
    np.testing.assert_array_equal(again.draws, posterior.draws)


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


def test_a_problem_without_a_collapsed_form_goes_to_emcee():
    """White noise offers no collapsed form: the fallback walks every parameter."""
    rng = np.random.default_rng(2)
    log = BenchLog(columns={"time_s": np.arange(300.0),
                            "drift_deg_h": 1.0 + rng.normal(0.0, 0.3, 300)})
    problem = BenchProblem.from_log(log, "bias", noise="white")
    posterior = Importance().sample(problem, problem.mode(), seed=0)
    assert posterior.method.startswith("emcee")
