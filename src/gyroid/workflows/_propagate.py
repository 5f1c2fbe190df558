"""From a fitted gyro's posterior to the roll-correction coefficient's relative error dK.

Each posterior draw of the FOG drift coefficients gives the gyro's drift history in a flight
scenario's environment (temperature rising through the flight, the Earth's field in the
gyro's axes); that drift is fed to paper B's correction loop (:mod:`gyroid.models._roll`) together
with the scenario's uncertain inputs (encoder-error phase, uncompensated rate, stabiliser
SF error and bias), vectorised over draws. Out come the distributions of dK, of the residual
SF error, of the roll-angle error and of the lateral position error; Sobol indices say which
input drives dK's uncertainty, JAX derivatives give the local sensitivities.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.inference._checks import CheckReport, fit_verdict
from gyroid.inference._posterior import interval_summary
from gyroid.io._fitted import FittedDrift
from gyroid.models import _paper_b as pb
from gyroid.models._drift import DriftModel
from gyroid.models._effects import EXTRA_PREFIX
from gyroid.models._inputs import T0_C, DriftInputs, inputs_from_arrays
from gyroid.models._roll import (
    MEMS_SATURATION_DEG_S,
    Flight,
    RollParams,
    correction_coefficients,
    navigation_errors,
)
from gyroid.simulation._flight import environment
from gyroid.workflows._scenarios import Scenario
from gyroid.workflows._sensitivity import sobol_indices

REPORT_TIMES_S = (10.0, 60.0, 120.0)


def flight_environment(scenario: Scenario, t0_C: float = T0_C) -> DriftInputs:
    """The drift model's inputs along the scenario's flight."""
    n = int(round(scenario.duration_s / scenario.sample_s))
    time_s = scenario.sample_s * (np.arange(n) + 1.0)
    # The body rolls, so the field turns in the SINS gyro's axes; the stabilised platform
    # keeps its orientation.
    sins_role = scenario.fitted_gyro_role == "sins"
    angle = scenario.roll_rate_deg_s * time_s if sins_role else np.zeros(n)
    temperature, rate, field = environment(
        time_s, scenario.duration_s, scenario.temperature_start_C, scenario.temperature_rise_C,
        scenario.earth_field_uT, angle)
    return inputs_from_arrays(time_s, temperature, rate, field, t0_C=t0_C, origin_s=0.0)


class _Evaluator(eqx.Module):
    model: DriftModel
    env: DriftInputs
    scenario: Scenario = eqx.field(static=True)

    def _setup(self, theta, phase, uncompensated, mems_sf, mems_bias_deg_s, roll_rate,
               sins_sf, encoder):
        s = self.scenario
        n = self.env.time_h.shape[0]
        drift = self.model.predict(theta, self.env) / 3600.0  # deg/s
        zeros = jnp.zeros(n)
        sins_role = s.fitted_gyro_role == "sins"
        flight = Flight(
            roll_rate_deg_s=jnp.full(n, 1.0) * roll_rate,
            uncompensated_deg_s=jnp.full(n, 1.0) * uncompensated,
            sins_drift_deg_s=drift if sins_role else zeros,
            sins_noise_deg_s=zeros,
            gs_noise_deg=zeros,
            gs_drift_deg_s=None if sins_role else drift,
            sample_s=s.sample_s,
            period_s=s.period_s,
            mems_range_deg_s=MEMS_SATURATION_DEG_S,
        )
        params = RollParams(D0=0.0, D1=sins_sf, D0gs=mems_bias_deg_s, D1gs=mems_sf,
                            Denc=encoder, encoder_phase=phase)
        return params, flight

    def dk(self, theta, phase, uncompensated, mems_sf, mems_bias_deg_s, roll_rate, sins_sf,
           encoder, period):
        """dK of one period only, from per-period sums (the fast path for Sobol indices)."""
        params, flight = self._setup(theta, phase, uncompensated, mems_sf, mems_bias_deg_s,
                                     roll_rate, sins_sf, encoder)
        return correction_coefficients(params, flight)[period]

    def one(self, theta, phase, uncompensated, mems_sf, mems_bias_deg_s, roll_rate, sins_sf,
            encoder, period=None):
        """Outputs for one set of inputs; ``period`` picks the correction period whose dK is
        reported (default: the one ending nearest mid-flight)."""
        s = self.scenario
        params, flight = self._setup(theta, phase, uncompensated, mems_sf, mems_bias_deg_s,
                                     roll_rate, sins_sf, encoder)
        idx = jnp.asarray([int(round(t / s.sample_s)) - 1 for t in REPORT_TIMES_S
                           if t <= s.duration_s])
        result = navigation_errors(params, flight, idx)
        if period is None:
            period = jnp.asarray(result.dK.shape[0] // 2)
        return {
            "dK": result.dK[period],
            "sf_residual_ppm": 1e6 * jnp.abs(result.residual_sf_error[period]),
            "saturated": result.peak_mems_deg_s >= MEMS_SATURATION_DEG_S,
            "dpsi_deg": result.angle_error_deg,
            "dr_z_m": result.lateral_error_m,
        }


@eqx.filter_jit
def _batch(evaluator: _Evaluator, theta, phase, uncompensated, mems_sf, mems_bias,
           roll_rate, sins_sf, encoder, period):
    return jax.vmap(evaluator.one)(theta, phase, uncompensated, mems_sf, mems_bias, roll_rate,
                                   sins_sf, encoder, period)


@eqx.filter_jit
def _batch_dk(evaluator: _Evaluator, theta, phase, uncompensated, mems_sf, mems_bias,
              roll_rate, sins_sf, encoder, period):
    return jax.vmap(evaluator.dk)(theta, phase, uncompensated, mems_sf, mems_bias, roll_rate,
                                  sins_sf, encoder, period)


def _evaluate(evaluator: _Evaluator, inputs: dict[str, np.ndarray], chunk: int = 256,
              dk_only: bool = False):
    n = inputs["drift"].shape[0]
    s = evaluator.scenario
    outs = []
    for start in range(0, n, chunk):
        sl = slice(start, start + chunk)
        m = inputs["drift"][sl].shape[0]
        batch = _batch_dk if dk_only else _batch
        outs.append(batch(
            evaluator, jnp.asarray(inputs["drift"][sl]), jnp.asarray(inputs["encoder_phase"][sl]),
            jnp.asarray(inputs["uncompensated"][sl]), jnp.asarray(inputs["mems_sf"][sl]),
            jnp.asarray(inputs["mems_bias"][sl]), jnp.full(m, s.roll_rate_deg_s),
            jnp.full(m, s.sins_sf_error), jnp.full(m, s.encoder_deg),
            jnp.asarray(inputs["period"][sl])))
    if dk_only:
        return {"dK": np.concatenate([np.asarray(o) for o in outs])}
    return {k: np.concatenate([np.asarray(o[k]) for o in outs]) for k in outs[0]}


def _samplers(scenario: Scenario, draws: np.ndarray):
    def drift(rng, n):
        return draws[rng.integers(0, draws.shape[0], n)]

    def phase(rng, n):
        if scenario.encoder_phase == "uniform":
            return rng.uniform(0.0, 2.0 * math.pi, n)
        return np.full(n, float(scenario.encoder_phase))

    def normal(mean, sd):
        return lambda rng, n: mean + sd * rng.standard_normal(n)

    n_periods = int(scenario.duration_s / scenario.sample_s) // int(
        round(scenario.period_s / scenario.sample_s))

    def period(rng, n):
        if scenario.period_index >= 0:
            return np.full(n, min(scenario.period_index, n_periods - 1))
        return rng.integers(0, n_periods, n)

    return {
        "drift": drift,
        "period": period,
        "encoder_phase": phase,
        "uncompensated": normal(scenario.uncompensated_deg_s, scenario.uncompensated_sd_deg_s),
        "mems_sf": normal(scenario.mems_sf_error, scenario.mems_sf_error_sd),
        "mems_bias": normal(scenario.mems_bias_deg_h / 3600.0,
                            scenario.mems_bias_sd_deg_h / 3600.0),
    }


DRIVER_NAMES = {"drift": "fitted drift coefficients", "period": "time in flight (period)",
                "encoder_phase": "encoder error",
                "uncompensated": "uncompensated rate", "mems_sf": "stabiliser SF error",
                "mems_bias": "stabiliser bias"}


@dataclass(frozen=True)
class Propagation:
    """A fitted gyro's posterior pushed through paper B's loop in one flight scenario.

    ``samples`` holds one value per simulated flight: ``dK`` (relative error of the
    correction coefficient), ``sf_residual_ppm``, ``saturated`` (the stabiliser's rate
    limit reached), and per report time (columns, ``report_times_s``) ``dpsi_deg`` (roll
    angle error) and ``dr_z_m`` (lateral position error)."""

    scenario: Scenario
    samples: dict[str, np.ndarray]
    report_times_s: tuple[float, ...]
    sobol: dict[str, dict[str, float]]  # per input: first-order S1 and total ST index
    sobol_samples: int
    local_sensitivity: dict[str, float]  # d dK / d input at the nominal point
    delta_method: dict
    dk_eq7: float  # paper B's eq. 7 for the scenario's nominal inputs
    fitted_terms: tuple[str, ...]
    posterior_draws: int
    checks: CheckReport

    @property
    def draws(self) -> int:
        return int(self.samples["dK"].size)

    @property
    def dk(self) -> dict:
        """dK's mean, sd and 95 % interval over the flights."""
        return interval_summary(self.samples["dK"])

    @property
    def trustworthy(self) -> bool:
        return self.checks.trustworthy

    def at_time(self, name: str, time_s: float) -> dict:
        """Mean, sd and 95 % interval of ``dpsi_deg`` or ``dr_z_m`` at a report time."""
        return interval_summary(self.samples[name][:, self.report_times_s.index(time_s)])

    def to_json(self) -> dict:
        """The contract's ``propagate.json``."""
        times = self.report_times_s
        return {
            "scenario": self.scenario.as_dict(),
            "draws": self.draws,
            "dK": self.dk,
            "dK_definition": "relative error (K_i - K_true) / K_true of the coefficient of "
                             "one correction period, the period drawn uniformly over the "
                             "flight",
            "saturated_fraction": float(np.mean(self.samples["saturated"])),
            "sf_residual_ppm": interval_summary(self.samples["sf_residual_ppm"]),
            "dpsi_deg": {f"{t:g}": self.at_time("dpsi_deg", t) for t in times},
            "dr_z_m": {f"{t:g}": self.at_time("dr_z_m", t) for t in times},
            **driver_shares(self.sobol),
            "sobol_samples": self.sobol_samples,
            "local_sensitivity": self.local_sensitivity,
            "delta_method": self.delta_method,
            "closed_form": {"dK_eq7": self.dk_eq7, "dK_printed": pb.WORKED_DK_PRINTED,
                            "note": "eq. 7 takes the encoder error at its full amplitude; the "
                                    "loop sees Denc (sin a_i - sin a_(i-1)), set by the "
                                    "phase"},
            "fitted": {"terms": list(self.fitted_terms),
                       "posterior_draws": self.posterior_draws},
            **self.checks.to_json(),
        }


def propagate(fitted: FittedDrift, scenario: Scenario, *, draws: int = 2000, seed: int = 0,
              sobol_n: int = 1000, progress: Callable[[str], None] | None = None
              ) -> Propagation:
    """Propagate the posterior through the scenario. ``progress`` is told each stage as it
    starts."""
    say = progress or (lambda _message: None)
    extra = [name for name in fitted.model.terms if name.startswith(EXTRA_PREFIX)]
    if extra:
        raise GyroidInputError(f"the fit has {', '.join(extra)}: a flight scenario has no such "
                               "quantity; refit without it to propagate")
    rng = np.random.default_rng(seed)
    evaluator = _Evaluator(model=fitted.model, env=flight_environment(scenario, fitted.t0_C),
                           scenario=scenario)
    samplers = _samplers(scenario, fitted.draws)
    inputs = {name: sample(rng, draws) for name, sample in samplers.items()}
    say(f"  {draws} flights through paper B's loop ...")
    out = _evaluate(evaluator, inputs)
    say(f"  Sobol indices: {(len(samplers) + 2) * sobol_n} more flights ...")
    sobol = sobol_indices(samplers, lambda x: _evaluate(evaluator, x, dk_only=True)["dK"],
                          sobol_n, rng)
    say("  local sensitivities and the delta method (JAX gradients) ...")
    nominal_dk, gradient = _nominal_dk(evaluator, _nominal_inputs(scenario, fitted.draws))
    eq7 = pb.dk_overloaded(scenario.mems_bias_deg_h / 3600.0, scenario.mems_sf_error,
                           scenario.uncompensated_deg_s, scenario.encoder_deg,
                           scenario.roll_rate_deg_s, scenario.period_s)
    return Propagation(
        scenario=scenario, samples=out,
        report_times_s=tuple(t for t in REPORT_TIMES_S if t <= scenario.duration_s),
        sobol=sobol, sobol_samples=sobol_n,
        local_sensitivity=_local_sensitivity(evaluator, gradient),
        delta_method=_delta_method(nominal_dk, gradient, scenario, fitted.draws),
        dk_eq7=float(eq7), fitted_terms=tuple(fitted.model.terms),
        posterior_draws=int(fitted.draws.shape[0]),
        checks=CheckReport((fit_verdict(fitted.trustworthy, "propagating it"),)))


#: An input takes part in interactions when its total Sobol index exceeds its first-order
#: index by more than this (a few times the estimators' noise at the default 1000 samples).
INTERACTION_MARGIN = 0.05


def driver_shares(sobol: dict[str, dict[str, float]]) -> dict:
    """propagate.json's variance decomposition of dK from first-order (S1) and total (ST)
    Sobol indices. ``drivers`` are the total indices normalised to sum to 1: each input's
    share of dK's variance with its interactions counted, so an input that acts only
    jointly with another (the encoder error with the period's end phase) is not shown as
    negligible, as its first-order index would show it."""
    first = {DRIVER_NAMES[k]: max(v["S1"], 0.0) for k, v in sobol.items()}
    total = {DRIVER_NAMES[k]: max(v["ST"], 0.0) for k, v in sobol.items()}
    norm = sum(total.values())
    return {
        "drivers": {k: (v / norm if norm > 0 else 0.0) for k, v in total.items()},
        "drivers_definition": "total Sobol indices normalised to sum to 1 (interactions "
                              "included); drivers_first_order and drivers_total are the raw "
                              "indices",
        "drivers_first_order": first,
        "drivers_total": total,
        "interactions": {
            "share": max(0.0, 1.0 - sum(first.values())),
            "involving": sorted(k for k in total if total[k] - first[k] > INTERACTION_MARGIN),
            "meaning": "the part of dK's variance no input explains alone (1 - sum of the "
                       "first-order indices) and the inputs whose total index exceeds their "
                       "first-order one",
        },
    }


def _nominal_inputs(scenario: Scenario, draws: np.ndarray) -> dict[str, float | np.ndarray]:
    phase = 0.0 if scenario.encoder_phase == "uniform" else float(scenario.encoder_phase)
    return {"drift": draws.mean(axis=0), "encoder_phase": phase,
            "uncompensated": scenario.uncompensated_deg_s, "mems_sf": scenario.mems_sf_error,
            "mems_bias": scenario.mems_bias_deg_h / 3600.0,
            "roll_rate": scenario.roll_rate_deg_s, "sins_sf": scenario.sins_sf_error,
            "encoder": scenario.encoder_deg}


_ORDER = ("drift", "encoder_phase", "uncompensated", "mems_sf", "mems_bias", "roll_rate",
          "sins_sf", "encoder")


@eqx.filter_jit
def _dk_value_and_gradient(evaluator: _Evaluator, args: tuple):
    """dK and its gradient in every input at ``args`` (in :data:`_ORDER`): one compiled call
    (run op by op, the flight's gradient took ~170 small compilations, 6 s on a cold
    cache)."""
    def dk(*inputs):
        return evaluator.one(*inputs)["dK"]

    return jax.value_and_grad(dk, argnums=tuple(range(len(args))))(*args)


def _nominal_dk(evaluator: _Evaluator, nominal: dict):
    """dK at the nominal inputs and its gradient in each of :data:`_ORDER`."""
    return _dk_value_and_gradient(evaluator, tuple(jnp.asarray(nominal[k], dtype=float)
                                                   for k in _ORDER))


def _local_sensitivity(evaluator: _Evaluator, grads) -> dict[str, float]:
    """d dK / d input at the nominal point (posterior mean, nominal scenario; ``grads``:
    :func:`_nominal_dk`'s)."""
    names = evaluator.model.parameter_names
    out = {f"{name} (per unit of the coefficient)": float(g)
           for name, g in zip(names, np.asarray(grads[0]), strict=True)}
    units = {"encoder_phase": "per rad", "uncompensated": "per deg/s", "mems_sf": "per unit",
             "mems_bias": "per deg/s", "roll_rate": "per deg/s", "sins_sf": "per unit",
             "encoder": "per deg"}
    for key, g in zip(_ORDER[1:], grads[1:], strict=True):
        out[f"{key} ({units[key]})"] = float(g)
    return out


def _delta_method(value, grads, scenario: Scenario, draws: np.ndarray) -> dict:
    """First-order mean and sd of dK from the gradient and the inputs' covariances, without
    the encoder phase (a uniform phase is far from linear: the delta method does not apply
    to it). ``value``, ``grads``: :func:`_nominal_dk`'s."""
    grads = [grads[i] for i in (0, 2, 3, 4)]
    cov_drift = np.cov(draws, rowvar=False).reshape(draws.shape[1], draws.shape[1])
    g0 = np.asarray(grads[0])
    variance = float(g0 @ cov_drift @ g0)
    variance += float(grads[1]) ** 2 * scenario.uncompensated_sd_deg_s**2
    variance += float(grads[2]) ** 2 * scenario.mems_sf_error_sd**2
    variance += float(grads[3]) ** 2 * (scenario.mems_bias_sd_deg_h / 3600.0) ** 2
    return {"mean": float(value), "sd": math.sqrt(variance),
            "excludes": "encoder phase",
            "note": "first order: 'mean' is dK at the nominal inputs (posterior mean, encoder "
                    "phase 0), not an average. It differs from the Monte-Carlo mean when the "
                    "encoder phase is drawn uniformly: dK depends on it through sines, far "
                    "from linearly, and averages over it to another value"}
