"""Noise models are objects: a new kind is one class (here one defined in this file), which
the bench problem, its mode, its sampler, its self-checks and fit.json read through the
abstract interface, with no change to the library."""

from typing import ClassVar

import jax.numpy as jnp
import numpy as np
import pytest

from gyroid.inference import BenchProblem, Emcee, fit
from gyroid.io import BenchLog
from gyroid.models._priors import LogNormal
from gyroid.noise import NOISE_MODELS, NoiseModel, White, noise_model
from gyroid.noise._kalman import gauss_markov_innovations, gauss_markov_mean_covariance

TAU_S = 120.0


class KnownTauGaussMarkov(NoiseModel):
    """White noise plus a Gauss-Markov bias whose correlation time a datasheet states
    (:data:`TAU_S`): two levels, not three."""

    name: ClassVar[str] = "white+gm(tau 120 s)"
    level_names: ClassVar[tuple[str, ...]] = ("sigma_deg_h", "sigma_gm_deg_h")
    units: ClassVar[dict[str, str]] = {"sigma_deg_h": "deg/h", "sigma_gm_deg_h": "deg/h"}
    correlated: ClassVar[bool] = True
    on_block_means: ClassVar[bool] = False
    remedies: ClassVar[tuple[str, ...]] = ("discrepancy",)

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {"sigma_deg_h": LogNormal(level_deg_h, 3.0),
                "sigma_gm_deg_h": LogNormal(level_deg_h, 3.0)}

    def fog_priors(self):
        return {"sigma_deg_h": LogNormal(1.0, 3.0), "sigma_gm_deg_h": LogNormal(0.05, 3.0)}

    def row_white_sd(self, values, *, step_s, row_scale):
        return values["sigma_deg_h"] * row_scale

    def start_levels(self, residual, white, *, step_s, row_scale, dof):
        level = float(np.std(residual))
        return ({"sigma_deg_h": level, "sigma_gm_deg_h": level},
                {"sigma_deg_h": 0.1, "sigma_gm_deg_h": 0.1})

    def sample_white_sd(self, values, sample_s):
        return float(values["sigma_deg_h"])

    def innovations(self, observed, white, values, clock):
        return gauss_markov_innovations(observed, clock.steps_s, white,
                                        values["sigma_gm_deg_h"], jnp.asarray(TAU_S),
                                        clock.weight)

    def part_covariance(self, time_s, part, n_parts, step_s, white_var, values, *,
                        block_means=False, after_s=None):
        return np.diag(white_var) + gauss_markov_mean_covariance(
            time_s, part, n_parts, values["sigma_gm_deg_h"], TAU_S)


def _log(seed: int, n: int = 3000) -> tuple[BenchLog, dict]:
    """bias + temperature with white noise and a Gauss-Markov bias of correlation time
    TAU_S, by an AR(1) recursion written here (not gyroid's simulator)."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(n, dtype=float)
    temperature = 20.0 + 10.0 * np.sin(2 * np.pi * time_s / n)
    truth = {"w0": 0.5, "w1": 0.05, "sigma_deg_h": 0.2, "sigma_gm_deg_h": 0.3}
    phi = np.exp(-1.0 / TAU_S)
    gm = np.empty(n)
    gm[0] = rng.normal(0.0, truth["sigma_gm_deg_h"])
    for k in range(1, n):
        gm[k] = phi * gm[k - 1] + rng.normal(0.0, truth["sigma_gm_deg_h"] * np.sqrt(1 - phi**2))
    drift = (truth["w0"] + truth["w1"] * (temperature - 21.0) + gm
             + rng.normal(0.0, truth["sigma_deg_h"], n))
    return BenchLog({"time_s": time_s, "drift_deg_h": drift, "temperature_C": temperature}), truth


def test_a_noise_model_defined_outside_the_library_fits_a_log():
    log, truth = _log(seed=11)
    problem = BenchProblem.from_log(log, "bias,temperature", noise=KnownTauGaussMarkov(),
                                    errors_in_variables=False)
    assert problem.names == ("w0", "w1", "sigma_deg_h", "sigma_gm_deg_h")
    result = fit(problem, sampler=Emcee(progress=False), seed=3)
    record = result.to_json()
    assert record["noise"]["model"] == "white+gm(tau 120 s)"
    assert record["noise"]["units"] == KnownTauGaussMarkov.units
    for name, value in truth.items():
        post = (record["posterior"] | record["noise"]["posterior"])[name]
        # 4 sd: a single seed (the levels' posteriors are log-normal-ish, sd a fair scale)
        assert abs(post["mean"] - value) < 4.0 * post["sd"], (name, post, value)
    assert result.trustworthy, result.summary()
    # the compensation's view of the fit: its own parts' covariance
    estimate = result.noise_estimate()
    # a level for prediction is its root mean square over the posterior
    white = record["noise"]["posterior"]["sigma_deg_h"]
    assert estimate.model is problem.noise and estimate.white_sd_deg_h == pytest.approx(
        np.hypot(white["mean"], white["sd"]))


def test_the_registry_names_each_kind_once():
    assert set(NOISE_MODELS) == {"white", "white+gm", "white+flicker+rw"}
    assert noise_model("white") == White() and noise_model(White()) == White()
    with pytest.raises(Exception, match="use one of white, white\\+gm, white\\+flicker\\+rw"):
        noise_model("pink")
