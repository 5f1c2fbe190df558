"""What a pooled fit gives (:class:`PoolResult`: ``pool.json``, InferenceData, a summary)
and the classical answer beside it: per coefficient, Cochran's Q of the runs' own estimates
(``sum (theta_r - weighted mean)**2 / s_r**2``, chi-square with R - 1 degrees of freedom
when the runs differ by noise alone) and I^2 = max(0, (Q - df) / Q), the share of the runs'
scatter that is between-run spread rather than noise."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np
from scipy import stats

from gyroid.inference._posterior import Posterior, interval_summary, summarise_draws
from gyroid.inference._problem import PointEstimate
from gyroid.inference._result import Fit
from gyroid.inference._storage import inference_data
from gyroid.models._effects import parameter
from gyroid.pool._checks import pool_checks

if TYPE_CHECKING:
    from gyroid.pool._problem import PoolProblem

#: Cochran's Q p-value below which the runs differ by more than their noise.
HETEROGENEITY_P = 0.05


@dataclass(frozen=True)
class Heterogeneity:
    """Cochran's Q of one coefficient over the runs' own estimates."""

    q: float
    dof: int
    p_value: float
    i_squared: float
    within_run_sd: float  # median of the runs' own sds

    def to_json(self) -> dict:
        return {"Q": self.q, "dof": self.dof, "p_value": self.p_value,
                "I2": self.i_squared, "within_run_sd": self.within_run_sd,
                "spread_beyond_noise": self.p_value < HETEROGENEITY_P}


@dataclass(frozen=True, eq=False)
class PoolFit(Fit["PoolProblem"]):
    """A pooled fit: the problem, its mode and posterior, the derived draws and checks."""

    mean_draws: np.ndarray = field(repr=False)  # (chains, draws, p) the population means
    run_draws: np.ndarray = field(repr=False)  # (M, R, p) each run's, M = chains x draws
    new_run_draws: np.ndarray = field(repr=False)  # (M, p) a new run's coefficients
    run_log_likelihood: np.ndarray = field(repr=False)  # (chains, draws, R) given mu, tau
    posterior_summary: dict[str, dict] = field(repr=False)  # of mu, tau and sigma
    heterogeneity: dict[str, Heterogeneity] = field(repr=False)

    def __repr__(self) -> str:
        verdict = "trustworthy" if self.trustworthy else "NOT trustworthy"
        return (f"PoolFit(terms={','.join(self.terms)!r}, runs={len(self.run_labels)}, "
                f"{verdict})")

    @property
    def terms(self) -> tuple[str, ...]:
        return self.problem.terms

    @property
    def coefficient_names(self) -> tuple[str, ...]:
        return self.problem.coefficient_names

    @property
    def run_labels(self) -> tuple[str, ...]:
        return self.problem.run_labels

    @property
    def own_mean(self) -> np.ndarray:
        return self.problem.own_mean

    @property
    def own_sd(self) -> np.ndarray:
        return self.problem.own_sd

    @property
    def n_samples(self) -> tuple[int, ...]:
        return tuple(q.n for q in self.problem.runs) or (0,) * len(self.run_labels)

    @property
    def rate_window_s(self) -> tuple[float, ...]:
        return (tuple(float(q.rate_window_s) for q in self.problem.runs)
                or (float("nan"),) * len(self.run_labels))

    @property
    def input_ranges(self) -> dict[str, list[float]]:
        """Every input's range over all the runs."""
        ranges = [q.model.input_ranges(q.inputs) for q in self.problem.runs]
        if not ranges:
            return {}
        return {k: [min(r[k][0] for r in ranges), max(r[k][1] for r in ranges)]
                for k in ranges[0]}

    def summary(self) -> str:
        """A few lines per coefficient: population mean, between-run sd, a new run, and
        whether the runs differ by more than their noise."""
        record = self.to_json()
        lines = [f"{len(self.run_labels)} runs; population mean +/- sd | between-run sd "
                 "(95 %) | new run +/- sd | Cochran's Q p"]
        for name in self.coefficient_names:
            mean, spread = record["population"][name], record["between_run_sd"][name]
            new = record["new_run_predictive"][name]
            h = self.heterogeneity.get(name)
            test = "" if h is None else f" | p = {h.p_value:.2g}" + (
                " (spread beyond noise)" if h.p_value < HETEROGENEITY_P else "")
            lo, hi = spread["ci95"]
            lines.append(f"  {name:>8s} = {mean['mean']: .4g} +/- {mean['sd']:.2g} | "
                         f"{spread['mean']:.3g} ({lo:.2g} ... {hi:.2g}) | "
                         f"{new['mean']: .4g} +/- {new['sd']:.2g}{test}")
        return "\n".join(lines)

    def inference_data(self):
        """ArviZ InferenceData: population means and between-run sds; each
        run's pooled coefficients (``run_<name>``, dims chain, draw, run) and a new run's
        (``new_run_<name>``); each run's log-likelihood (LOO leaves out runs)."""
        shape = self.mean_draws.shape[:2]
        post = self.sampled
        posterior = {n: self.mean_draws[..., k] for k, n in enumerate(self.coefficient_names)}
        posterior |= {n: post.draws[..., i] for i, n in enumerate(self.problem.names)}
        for k, name in enumerate(self.coefficient_names):
            posterior[f"run_{name}"] = self.run_draws[:, :, k].reshape(*shape, -1)
            posterior[f"new_run_{name}"] = self.new_run_draws[:, k].reshape(shape)
        return inference_data(
            self.problem, post, log_likelihood={"run_estimate": self.run_log_likelihood},
            extra_posterior={k: v for k, v in posterior.items() if k not in self.problem.names},
            coords={"run": list(self.run_labels)},
            dims={"run_estimate": ["run"], **{f"run_{n}": ["run"]
                                            for n in self.coefficient_names}})

    def to_json(self) -> dict:
        """The contract's ``pool.json`` (plus units, priors, own estimates, heterogeneity)."""
        names = self.coefficient_names
        summary = self.posterior_summary
        spread = self.problem.spread_names
        out: dict = {
            "terms": list(self.terms),
            "runs": list(self.run_labels),
            "n_samples": dict(zip(self.run_labels, self.n_samples, strict=True)),
            "population": {n: dict(summary[n]) for n in names},
            "between_run_sd": {n: dict(summary[s]) for n, s in zip(names, spread,
                                                                         strict=True)},
            "per_run": {
                label: {n: interval_summary(self.run_draws[:, r, k]) for k, n in enumerate(names)}
                for r, label in enumerate(self.run_labels)
            },
            "new_run_predictive": {n: interval_summary(self.new_run_draws[:, k])
                                   for k, n in enumerate(names)},
            "own_estimates": {
                label: {n: {"mean": float(self.own_mean[r, k]),
                            "sd": _finite(self.own_sd[r, k])} for k, n in enumerate(names)}
                for r, label in enumerate(self.run_labels)
            },
            "heterogeneity": {n: h.to_json() for n, h in self.heterogeneity.items()},
            "run_noise": self.problem.idata_attrs()["run_noise"],
            "run_noise_levels": ({label: estimate.to_json() for label, estimate in zip(
                self.run_labels, self.problem.run_noise_levels, strict=True)}
                if self.problem.run_noise_levels else {}),
            "units": {n: parameter(n).unit for n in names},
            "priors": {n: prior.describe() for n, prior in zip(
                names + self.problem.names, self.problem.mean_priors + self.problem.priors,
                strict=True)},
            "t0_C": self.problem.t0_C,
            "rate_window_s": dict(zip(self.run_labels, self.rate_window_s, strict=True)),
            "input_ranges": self.input_ranges,
            "seed": self.seed,
            "segment_means": self.problem.segment_means,
            "convergence": {
                "point_estimate": self.point.message,
                "sampler": {
                    "method": self.sampled.method,
                    "chains": int(self.sampled.draws.shape[0]),
                    "steps": self.sampled.n_steps,
                    "divergent": self.sampled.divergent,
                    "draws_kept": int(np.prod(self.sampled.draws.shape[:2])),
                    "r_hat_max": max(s["r_hat"] for s in summary.values()),
                    "ess_bulk_min": min(s["ess_bulk"] for s in summary.values()),
                },
            },
            "model": "theta_run ~ N(population mean, between_run_sd**2) per coefficient; "
                     + ("each run's own fit's posterior one Gaussian observation of its "
                        "coefficients (its noise model its own)" if self.problem.run_noise
                        else "each run's published estimate one Gaussian observation")
                     + "; runs' coefficients integrated out exactly and drawn from their "
                     "conditional",
            **self.checks.to_json(),
        }
        return out


def _finite(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


def heterogeneity(names: tuple[str, ...], own_mean: np.ndarray, own_sd: np.ndarray
                  ) -> dict[str, Heterogeneity]:
    """Cochran's Q and I^2 per coefficient over the runs that identify it."""
    out = {}
    for k, name in enumerate(names):
        ok = np.isfinite(own_mean[:, k]) & np.isfinite(own_sd[:, k]) & (own_sd[:, k] > 0)
        if ok.sum() < 2:
            continue
        x, s = own_mean[ok, k], own_sd[ok, k]
        w = 1.0 / s**2
        centre = np.sum(w * x) / np.sum(w)
        q = float(np.sum(w * (x - centre) ** 2))
        dof = int(ok.sum() - 1)
        out[name] = Heterogeneity(q=q, dof=dof, p_value=float(stats.chi2.sf(q, dof)),
                                  i_squared=max(0.0, (q - dof) / q) if q > 0 else 0.0,
                                  within_run_sd=float(np.median(s)))
    return out


def pool_result(problem: PoolProblem, point: PointEstimate, posterior: Posterior | None, *,
                seed: int) -> PoolFit:
    """The :class:`PoolFit` of a pooled problem: the population means, the runs' and a new
    run's coefficients drawn per posterior draw, then the checks."""
    if posterior is None:
        raise ValueError("a pooled fit needs its posterior (the population is drawn from it)")
    mean_draws, run_draws, new_draws, run_log_lik = derived_draws(problem, posterior,
                                                                  seed=seed)
    names = problem.coefficient_names
    summary = summarise_draws(mean_draws, names) | posterior.summary
    return PoolFit(
        problem=problem, point=point, posterior=posterior, seed=seed,
        mean_draws=mean_draws, run_draws=run_draws, new_run_draws=new_draws,
        run_log_likelihood=run_log_lik, posterior_summary=summary,
        heterogeneity=heterogeneity(names, problem.own_mean, problem.own_sd),
        checks=pool_checks(problem, point, posterior, mean_draws, summary))


def derived_draws(problem: PoolProblem, posterior: Posterior, *, seed: int):
    """Per posterior draw of the between-run sds: the population means
    from their exact conditional, every run's coefficients from theirs, a new run's from
    the population, and each run's log-likelihood. Returns (chains, draws, p), (M, R, p),
    (M, p), (chains, draws, R)."""
    chains, draws, d = posterior.draws.shape
    u = np.log(posterior.draws.reshape(-1, d))
    rng = np.random.default_rng([seed, 1])
    p, r = problem.n_model, problem.n_runs
    z_mean = rng.standard_normal((u.shape[0], p))
    z_runs = rng.standard_normal((u.shape[0], r, p))
    z_new = rng.standard_normal((u.shape[0], p))
    mean, runs, log_lik, _ = _conditional_draws(problem.density, jnp.asarray(u),
                                                jnp.asarray(z_mean), jnp.asarray(z_runs))
    mean = np.asarray(mean)
    new = mean + np.exp(u[:, :p]) * z_new
    return (mean.reshape(chains, draws, p), np.asarray(runs), new,
            np.asarray(log_lik).reshape(chains, draws, r))


@jax.jit
def _conditional_draws(density, u, z_mean, z_runs):
    # A loop over draws (lax.map), each batched over runs only: the same draws vmapped over
    # thousands of draws at once sometimes never returned on XLA's CPU runtime (jax 0.10.2;
    # idle threads, a lost wake-up; 30 runs x 1000 draws hung where 30 x 2000 did not).
    def one(args):
        u, z_mean, z_runs = args
        mu = density.mean_conditional(u, z_mean)
        return (mu, density.run_coefficients(mu, u, z_runs), density.run_log_likelihood(mu, u),
                density.run_consistency(mu, u))

    return jax.lax.map(one, (u, z_mean, z_runs))


