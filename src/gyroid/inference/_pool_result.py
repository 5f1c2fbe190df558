"""What a pooled fit gives (:class:`PoolResult`: ``pool.json``, InferenceData, a summary)
and the classical answer beside it: per coefficient, Cochran's Q of the runs' own estimates
(``sum (theta_r - weighted mean)**2 / s_r**2``, chi-square with R - 1 degrees of freedom
when the runs differ by noise alone) and I^2 = max(0, (Q - df) / Q), the share of the runs'
scatter that is between-run spread rather than noise."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from gyroid.inference._check_report import CheckReport
from gyroid.inference._point import PointEstimate
from gyroid.inference._pool_problem import PoolProblem
from gyroid.inference._sampling import Posterior, interval_summary
from gyroid.models._effects import parameter
from gyroid.models._inputs import T0_C

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


@dataclass
class PoolResult:
    """A pooled fit: the problem, its mode and posterior, the derived draws and checks."""

    problem: PoolProblem
    point: PointEstimate
    posterior: Posterior
    terms: tuple[str, ...]
    own_mean: np.ndarray  # (R, p) each run's own least-squares coefficients
    own_sd: np.ndarray  # (R, p) their sds (nan where a run does not identify one)
    mean_draws: np.ndarray  # (chains, draws, p) the population means
    run_draws: np.ndarray  # (M, R, p) each run's pooled coefficients, M = chains x draws
    new_run_draws: np.ndarray  # (M, p) a new run's coefficients
    run_log_likelihood: np.ndarray  # (chains, draws, R) each run's, given mu, tau, sigma
    summary: dict[str, dict]  # mean, sd, ci95, r_hat, ess_bulk of mu, tau and sigma
    heterogeneity: dict[str, Heterogeneity]
    n_samples: tuple[int, ...] = ()
    t0_C: float = T0_C
    rate_window_s: tuple[float, ...] = ()
    input_ranges: dict[str, list[float]] = field(default_factory=dict)
    seed: int = 0
    segment_means: bool = False  # burst logs pooled on one row per burst
    checks: CheckReport = field(default_factory=lambda: CheckReport(()))

    @property
    def trustworthy(self) -> bool:
        return self.checks.trustworthy

    @property
    def coefficient_names(self) -> tuple[str, ...]:
        return self.problem.coefficient_names

    @property
    def run_labels(self) -> tuple[str, ...]:
        return self.problem.run_labels

    def summary_text(self) -> str:
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

    def idata(self):
        """ArviZ InferenceData: population means, between-run sds and noise levels; each
        run's pooled coefficients (``run_<name>``, dims chain, draw, run) and a new run's
        (``new_run_<name>``); each run's log-likelihood (LOO leaves out runs)."""
        from gyroid.io._arviz import arviz as az

        shape = self.mean_draws.shape[:2]
        post = self.posterior
        posterior = {n: self.mean_draws[..., k] for k, n in enumerate(self.coefficient_names)}
        posterior |= {n: post.draws[..., i] for i, n in enumerate(self.problem.names)}
        for k, name in enumerate(self.coefficient_names):
            posterior[f"run_{name}"] = self.run_draws[:, :, k].reshape(*shape, -1)
            posterior[f"new_run_{name}"] = self.new_run_draws[:, k].reshape(shape)
        observed = self.problem.observed_data()
        return az.from_dict(
            posterior=posterior,
            log_likelihood={"run_n_rows": self.run_log_likelihood},
            observed_data=observed,
            sample_stats={"lp": post.log_posterior},
            coords={"run": list(self.run_labels)},
            dims={"run_n_rows": ["run"], **{f"run_{n}": ["run"]
                                            for n in self.coefficient_names}},
            attrs={**self.problem.idata_attrs(),
                   "sampler": f"{post.move} on the between-run sds and noise levels; "
                              "population means and runs' coefficients drawn from their "
                              "exact conditionals"},
        )

    def to_json(self) -> dict:
        """The contract's ``pool.json`` (plus units, priors, own estimates, heterogeneity)."""
        names = self.coefficient_names
        summary = self.summary
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
            "noise": {name: dict(summary[name]) for name in self.problem.noise_names},
            "units": {n: parameter(n).unit for n in names},
            "priors": {n: prior.describe() for n, prior in zip(
                names + self.problem.names, self.problem.mean_priors + self.problem.priors,
                strict=True)},
            "t0_C": self.t0_C,
            "rate_window_s": dict(zip(self.run_labels, self.rate_window_s, strict=True)),
            "input_ranges": self.input_ranges,
            "seed": self.seed,
            "segment_means": self.segment_means,
            "convergence": {
                "point_estimate": self.point.message,
                "sampler": {
                    "method": self.posterior.move,
                    "chains": int(self.posterior.draws.shape[0]),
                    "steps": self.posterior.n_steps,
                    "divergent": self.posterior.divergent,
                    "draws_kept": int(np.prod(self.posterior.draws.shape[:2])),
                    "r_hat_max": max(s["r_hat"] for s in summary.values()),
                    "ess_bulk_min": min(s["ess_bulk"] for s in summary.values()),
                },
            },
            "model": "theta_run ~ N(population mean, between_run_sd**2) per coefficient; "
                     "each run's white noise its own; runs' coefficients integrated out "
                     "exactly (linear model) and drawn from their conditional",
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
