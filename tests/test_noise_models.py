"""Noise models are tuples of terms: a new model is one line (Kalibr's white + rate random
walk, here), a new term one class (one defined in this file), which the bench problem, its
mode, its sampler, its self-checks and fit.json read through the model, with no change to
the library."""

from typing import ClassVar

import jax.numpy as jnp
import numpy as np
import pytest

from gyroid.bench import BenchOptions, BenchProblem
from gyroid.inference import Emcee, fit
from gyroid.io import BenchLog
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.models._priors import LogNormal
from gyroid.noise import (
    NOISE_MODELS,
    AbstractNoiseTerm,
    AngleRandomWalk,
    NoiseModel,
    RateRandomWalk,
    SampleWhite,
    noise_model,
)

TAU_S = 120.0


class KnownTauBias(AbstractNoiseTerm):
    """A Gauss-Markov bias whose correlation time a datasheet states (:data:`TAU_S`): one
    level, its sd."""

    code: ClassVar[str] = "G"
    level_names: ClassVar[tuple[str, ...]] = ("sigma_gm_deg_h",)
    units: ClassVar[dict[str, str]] = {"sigma_gm_deg_h": "deg/h"}
    over_spans: ClassVar[bool] = False
    wanders: ClassVar[bool] = False

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {"sigma_gm_deg_h": LogNormal(level_deg_h, 3.0)}

    def fog_priors(self):
        return {"sigma_gm_deg_h": LogNormal(0.05, 3.0)}

    def start(self, residual, white, *, step_s, row_scale, dof, alone):
        return {"sigma_gm_deg_h": float(np.std(residual))}, {"sigma_gm_deg_h": 0.1}

    def processes(self, values):
        return jnp.full((1,), TAU_S), values["sigma_gm_deg_h"], 1.0


KNOWN_TAU = NoiseModel("white+gm(tau 120 s)", (SampleWhite(), KnownTauBias()))
#: Kalibr's and OpenVINS's gyro noise: white noise and a rate random walk, no flicker.
KALIBR = NoiseModel("white+rw", (AngleRandomWalk(), RateRandomWalk()))


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


@pytest.mark.slow
def test_a_noise_model_defined_outside_the_library_fits_a_log():
    log, truth = _log(seed=11)
    problem = BenchProblem.from_log(log, "bias,temperature", BenchOptions(noise=KNOWN_TAU))
    assert problem.names == ("w0", "w1", "sigma_deg_h", "sigma_gm_deg_h")
    result = fit(problem, sampler=Emcee(progress=False), seed=3)
    record = result.to_json()
    assert record["noise"]["model"] == "white+gm(tau 120 s)"
    assert record["noise"]["units"] == {"sigma_deg_h": "deg/h", "sigma_gm_deg_h": "deg/h"}
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


def _walked_thermal_log(seed: int, n: int = 2400, step_s: float = 15.0
                        ) -> tuple[BenchLog, dict]:
    """Paper A's thermal drift (w0 + w1 t + w2 t^2 + wD dT/dt, t = T - 21 degC) on a bench
    cycled smoothly between 20 and 50 degC every 5 h, with white noise of angle random walk
    N, a rate random walk K (a cumulative sum of Gaussian steps) and a thermometer read with
    0.02 degC of white noise: written here, not gyroid's simulator."""
    rng = np.random.default_rng(seed)
    time_s = step_s * np.arange(n)
    phase = 2.0 * np.pi * time_s / (5.0 * 3600.0)
    temperature = 35.0 - 15.0 * np.cos(phase)
    rate = 15.0 * 2.0 * np.pi / 5.0 * np.sin(phase)  # degC/h
    truth = {"w0": 0.8, "w1": -0.05, "w2": 0.002, "wD": 0.4, "N_deg_sqrt_h": 0.05,
             "K_deg_h_sqrt_h": 0.3}
    t = temperature - 21.0
    white = rng.normal(0.0, 60.0 * truth["N_deg_sqrt_h"] / np.sqrt(step_s), n)
    walk = np.cumsum(rng.normal(0.0, truth["K_deg_h_sqrt_h"] / 60.0 * np.sqrt(step_s), n))
    drift = (truth["w0"] + truth["w1"] * t + truth["w2"] * t**2 + truth["wD"] * rate
             + white + walk - walk.mean())
    log = BenchLog({"time_s": time_s, "drift_deg_h": drift,
                    "temperature_C": temperature + rng.normal(0.0, 0.02, n)})
    return log, truth


@pytest.mark.slow
def test_a_model_of_one_line_fits_a_thermal_log_and_carries_its_thermometer():
    """Kalibr's white + rate random walk, defined above in one line, fits paper A's thermal
    model on a log with a noisy thermometer: the filter carries the thermometer's noise
    through dT/dt as one more term (no hook to override), and every coefficient and level
    is within 4 posterior sds of the truth (one seed)."""
    log, truth = _walked_thermal_log(seed=5)
    problem = BenchProblem.from_log(log, "thermal",
                                    BenchOptions(noise=KALIBR, rate_window_s=RATE_WINDOW_S))
    assert problem.noise.carried is not None and problem.thermometer_sd_C > 0.01
    assert problem.noise_names == ("N_deg_sqrt_h", "K_deg_h_sqrt_h")
    result = fit(problem, seed=2)
    record = result.to_json()
    assert record["noise"]["model"] == "white+rw"
    for name, value in truth.items():
        post = (record["posterior"] | record["noise"]["posterior"])[name]
        assert abs(post["mean"] - value) < 4.0 * post["sd"], (name, post, value)


def test_the_registry_names_each_model_once():
    assert set(NOISE_MODELS) == {"white", "white+gm", "white+flicker+rw"}
    white = NOISE_MODELS["white"]
    assert noise_model("white") is white and noise_model(white) is white
    assert noise_model(None) is white and noise_model("auto").name == "white+flicker+rw"
    assert NOISE_MODELS["white+gm"].level_names == ("sigma_deg_h", "sigma_gm_deg_h",
                                                    "tau_gm_s")
    # a model carrying the wander fits a burst log's samples whatever is asked: no
    # --segment-means among its remedies
    assert KALIBR.remedies == ("noise_terms", "discrepancy")
    assert noise_model("auto").remedies == ("discrepancy",)
    with pytest.raises(ValueError, match="first term is white"):
        NoiseModel("rw", (RateRandomWalk(),))
    with pytest.raises(Exception, match="use one of white, white\\+gm, white\\+flicker\\+rw"):
        noise_model("pink")


def test_the_drift_fit_and_the_static_fit_share_their_terms():
    """One vocabulary: IEEE 952's N, B and K (and the Gauss-Markov bias G) are the same
    classes in the drift likelihood and in ``gyroid noise``'s Allan variance, and the
    levels a static fit's noise.json gives the drift fit as priors are named by those
    terms' own letters."""
    from gyroid.noise import STATIC_TERMS

    static = {type(t): t.code for t in STATIC_TERMS}
    ieee = noise_model("white+flicker+rw")
    assert [static[type(t)] for t in ieee.terms] == ["N", "B", "K"]
    assert static[type(NOISE_MODELS["white+gm"].terms[1])] == "G"
    assert ieee.static_fit == {"N_deg_sqrt_h": "N", "B_deg_h": "B", "K_deg_h_sqrt_h": "K"}
    assert all(static[type(t)] == t.code for t in ieee.terms)
