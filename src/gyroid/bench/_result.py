"""A fitted bench log (:class:`BenchFit`: ``fit.json``, InferenceData, predictions, a
summary) and the self-checks of a bench fit: what :func:`bench_result` builds of a
:class:`~gyroid.bench.BenchProblem` (its :meth:`~gyroid.bench.BenchProblem.result`; the
problem is named here for the type checker only)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyroid.bench._allowed_noise import AllowedNoise, allowed_noise
from gyroid.bench._checks import bench_checks
from gyroid.inference._batching import problem_batcher
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import PointEstimate
from gyroid.inference._result import Fit
from gyroid.inference._storage import inference_data
from gyroid.io._fitted import FittedDrift
from gyroid.io._logs import BenchLog
from gyroid.models._design import rows_of
from gyroid.models._effects import parameter
from gyroid.models._priors import Prior
from gyroid.models._rate_error import one_sided_rows
from gyroid.noise._base import predictive_level
from gyroid.noise._estimate import NoiseEstimate

if TYPE_CHECKING:
    from gyroid.bench._problem import BenchProblem


@dataclass(frozen=True)
class NoisePriorSource:
    """A bench fit's noise priors' source (a datasheet, a noise fit's folder) and the
    levels it set (the others keep their defaults)."""

    source: str
    levels: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class BenchFit(Fit["BenchProblem"]):
    """A fitted bench log: its problem, point estimate, posterior (None when only the mode
    was asked for) and self-checks."""

    #: How the noise model was chosen: asked for by name, or by ``--noise auto`` and why.
    noise_choice: str = ""
    #: Each coefficient's range over the noise levels the log cannot rule out (None under
    #: white noise or without a posterior).
    allowed_noise: AllowedNoise | None = field(default=None, repr=False)
    #: Where the noise levels' priors came from (``--noise DIR`` or ``FILE.toml``), if
    #: anywhere: the source and the levels it set.
    noise_priors_from: NoisePriorSource | None = None

    def __repr__(self) -> str:
        verdict = "trustworthy" if self.trustworthy else "NOT trustworthy"
        return (f"BenchFit(terms={','.join(self.problem.model.terms)!r}, "
                f"n_samples={self.n_samples}, noise={self.problem.noise.name!r}, {verdict})")

    @property
    def model_names(self) -> tuple[str, ...]:
        return self.problem.model.parameter_names

    @property
    def t0_C(self) -> float:
        return self.problem.t0_C

    @property
    def fitted_log(self) -> BenchLog:
        """The log the model was fitted to (a burst log's segment means when asked)."""
        return self.problem.log

    @property
    def segment_means(self) -> dict[str, int] | None:
        """For a fit of a burst log's segment means: how many means, of how many rows."""
        problem = self.problem
        return {"segments": problem.n, "rows": problem.samples_behind.n} if (
            problem.reads_segment_means) else None

    @property
    def block_means(self) -> dict[str, int] | None:
        """For a fit of a long log's block means (white+flicker+rw, or white noise carrying
        the thermometer's): how many means, of how many samples each, of how many rows."""
        problem = self.problem
        return None if problem.block_rows == 1 else {
            "means": problem.n, "rows_per_mean": problem.block_rows,
            "rows": problem.samples_behind.n}

    @property
    def n_samples(self) -> int:
        """The log's samples fitted: for a fit of block means, the samples behind them."""
        problem = self.problem
        return problem.samples_behind.n if problem.block_rows > 1 else problem.n

    @property
    def rms_residual_deg_h(self) -> float:
        """The RMS of the drift's residuals at the point estimate over the samples (deg/h):
        for a fit of block means, the means' residuals (each for its block's samples, the
        model barely changing within a block) and the samples about their means."""
        problem, rms = self.problem, self.point.rms_residual
        if problem.block_rows == 1:
            return rms
        samples = problem.samples_behind
        within = samples.z_sum_sq * samples.within_sd**2
        return math.sqrt((problem.block_rows * problem.n * rms**2 + within) / samples.n)

    @property
    def errors_in_variables(self) -> dict | None:
        """For a fit that carries the thermometer's noise through the dT/dt estimator: that
        noise (a sample's sd, degC, measured on the log) and how."""
        problem = self.problem
        noise = problem.density.noise
        if noise.carried is None:
            return None
        carried = {"thermometer_sd_C": problem.thermometer_sd_C,
                   "wD_fixed": problem.rate_error_wd}
        one_sided = one_sided_rows(np.asarray(problem.log.time_s), problem.rate_window_s)
        how = ("the thermometer's white noise, measured by the logged temperature's third "
               "differences, passed through the dT/dt estimator and times wD's least-squares "
               "value (wD_fixed): ")
        term = noise.carried_process
        if term is None:  # beside white noise alone
            return carried | {"process": None, "one_sided_rows": int(one_sided.sum()),
                              "one_sided_exact": True, "one_sided_shift_sd": None,
                              "how": how + "a covariance wD^2 v L L' over the rows beside the "
                                           "white noise's, exact"}
        exact = term.ends is not None
        shift = float(term.one_sided_shift_sd)
        how += ("in the log's interior a process of the noise model's "
                "filter, oscillators' velocities matched to the estimator's error with its "
                "power at low frequencies (divergence_left: the share of the divergence "
                "from leaving it out that remains); on the one-sided rows within half a "
                "window of either end, "
                + ("their exact error and its covariance with every row" if exact else
                   "the same process: their exact error would move no coefficient by more "
                   f"than {shift:.2g} of its sd (one_sided_shift_sd)"))
        process = term.process
        oscillators = [{"sd_deg_h": math.sqrt(float(v)), "omega_rad_s": float(w),
                        "quality": float(q)} for v, w, q in np.asarray(process.oscillators)]
        return carried | {
            "process": {"oscillators": oscillators,
                        "divergence_left": float(process.divergence)
                        / max(float(process.divergence_without), 1e-300)},
            "one_sided_rows": int(one_sided.sum()),
            "one_sided_exact": exact,
            "one_sided_shift_sd": shift if math.isfinite(shift) else None,
            "how": how}

    @property
    def input_ranges(self) -> dict[str, list[float]]:
        """The range of every input the model reads, as seen in the fitted log."""
        return self.problem.model.input_ranges(self.problem.inputs)

    def point_summary(self) -> str:
        """The point estimate as the console shows it; where its search stopped and a
        converged posterior stands, also why that posterior is the answer (the convergence
        check's message), so that a stopped mode is never followed by a bare verdict."""
        text = self.point.summary()
        convergence = next((c for c in self.checks.checks if c.name == "convergence"), None)
        if not self.point.converged and convergence is not None and convergence.passed:
            text += f"\n{convergence.message}"
        return text

    def summary(self) -> str:
        """Each coefficient's posterior (or point estimate) and the failed self-checks."""
        names = self.problem.names
        source = (self.posterior.summary if self.posterior is not None else
                  {n: {"mean": self.point.value[n], "sd": self.point.sd[n]} for n in names})
        kind = "posterior mean +/- sd" if self.posterior is not None else "point estimate"
        carried = ("" if not self.errors_in_variables else
                   f", the thermometer's {self.problem.thermometer_sd_C:.3g} degC noise "
                   "carried through dT/dt")
        lines = [f"{','.join(self.problem.model.terms)} on {self.problem.n} rows "
                 f"({self.problem.noise.name} noise{carried}); {kind}:"]
        for name in names:
            unit = self.problem.noise.units.get(name) or parameter(name).unit
            lines.append(f"  {name:>16s} = {source[name]['mean']: .6g} +/- "
                         f"{source[name]['sd']:.3g} {unit}")
        lines += [f"  {line}" for line in self.checks.lines()]
        lines.append(f"  {self.checks.verdict()}")
        return "\n".join(lines)

    def fitted_drift(self) -> FittedDrift:
        """The drift model and its posterior draws of the coefficients, for compensation
        and propagation."""
        if self.posterior is None:
            raise ValueError("a fit without a posterior has no draws; fit with sample=True")
        p = self.problem.n_model
        draws = self.posterior.draws.reshape(-1, len(self.problem.names))[:, :p]
        return FittedDrift(model=self.problem.model, draws=draws, t0_C=self.t0_C,
                           rate_window_s=float(self.problem.rate_window_s),
                           trustworthy=self.trustworthy, input_ranges=self.input_ranges,
                           noise=self.noise_estimate(),
                           contributions=self.effect_contributions())

    def effect_contributions(self, max_rows: int = 1000) -> dict:
        """Each effect's contribution to the drift at the posterior means (else the point
        estimate), deg/h, at every ``every``-th fitted row (at most ``max_rows``): what an
        export needs to state the drift a target cannot represent (``fit.json``)."""
        import jax.numpy as jnp

        names = self.model_names
        source = (self.posterior.summary if self.posterior is not None else
                  {n: {"mean": self.point.value[n]} for n in names})
        params = {n: jnp.asarray(source[n]["mean"]) for n in names}
        every = max(1, -(-self.problem.n // max_rows))
        return {"every": every, "rows": self.problem.n, "effects": {
            e.name: np.asarray(e.contribution(params, self.problem.inputs))[::every]
            for e in self.problem.model.effects}}

    def noise_estimate(self) -> NoiseEstimate:
        """The noise model with its levels (each the root mean square over the posterior,
        :func:`~gyroid.noise.predictive_level`, else the point estimate) and a sample's
        white sd (deg/h; the median of a log's ``sigma_deg_h`` when it gives them) at the
        samples' interval (s; not for a fit of segment means)."""
        names = self.problem.noise_names
        source = (self.posterior.summary if self.posterior is not None else
                  {n: {"mean": self.point.value[n]} for n in names})
        levels = {n: predictive_level(source[n]) for n in names}
        density = self.problem.density
        sample_s = density.step_s / self.problem.block_rows
        if density.sigma is None:
            white = self.problem.noise.sample_white_sd(levels, sample_s)
        else:
            white = float(np.median(np.asarray(density.sigma)))
        time_s = np.asarray(self.problem.log.time_s)
        return NoiseEstimate(model=self.problem.noise, levels=levels, white_sd_deg_h=white,
                             white_sample_s=sample_s if self.segment_means is None else None,
                             span_s=float(time_s[-1] - time_s[0]) + density.step_s)

    def noise_levels(self) -> dict:
        """:meth:`noise_estimate` as fit.json writes it: ``model`` (the noise model's name),
        ``white_sd_deg_h``, ``white_sample_s``, ``span_s`` and each level by name."""
        return self.noise_estimate().to_json()

    def inference_data(self):
        """ArviZ InferenceData: posterior, block log-likelihoods (LOO), observed data."""
        if self.posterior is None:
            raise ValueError("a fit without a posterior has no InferenceData")
        return inference_data(self.problem, self.posterior)

    def predict_draws(self, n_draws: int = 200, seed: int = 0, every: int = 1) -> np.ndarray:
        """Modelled drift (deg/h) for ``n_draws`` posterior draws at every ``every``-th row:
        (n_draws, ceil(n / every)). A linear model is its design matrix's rows times the
        draws at the rows kept; otherwise the model runs over the whole log for a few draws at a
        time (memory O(n))."""
        problem = self.problem
        if self.posterior is None:
            return problem.predict(self.point.u)[None, ::every]
        flat = self.posterior.draws.reshape(-1, len(problem.names))
        rng = np.random.default_rng(seed)
        pick = rng.choice(flat.shape[0], size=min(n_draws, flat.shape[0]), replace=False)
        model = problem.model
        if model.is_linear:
            design = np.asarray(model.design(rows_of(problem.inputs, slice(None, None, every))))
            return flat[pick, : problem.n_model] @ design.T
        u = problem.to_sampling_host(flat[pick])
        predict = problem_batcher(problem.density.predict)
        chunk = int(np.clip(2e6 // max(problem.n, 1), 1, 64))
        return np.concatenate([np.asarray(predict(u[start:start + chunk]))[:, ::every]
                               for start in range(0, u.shape[0], chunk)])

    def to_json(self) -> dict:
        """The contract's ``fit.json`` (plus noise, units and convergence sections)."""
        problem, point, post = self.problem, self.point, self.posterior
        names, noise_names = self.model_names, problem.noise_names
        out: dict = {
            "terms": list(problem.model.terms),
            "n_samples": self.n_samples,
            "point": {k: point.value[k] for k in names},
            "point_sd": {k: point.sd[k] for k in names},
            "posterior": {},
            "rms_residual_deg_h": self.rms_residual_deg_h,
            "units": {k: parameter(k).unit for k in names},
            "t0_C": self.t0_C,
            "seed": self.seed,
            "noise": {
                "model": problem.noise.name,
                "sigma_from_log": problem.sigma_known,
                "point": {k: point.value[k] for k in noise_names},
                "point_sd": {k: point.sd[k] for k in noise_names},
                "posterior": {},
                "units": {k: problem.noise.units[k] for k in noise_names},
                **{k: v for k, v in self.noise_levels().items()
                   if k in ("white_sd_deg_h", "white_sample_s", "span_s")},
                "errors_in_variables": self.errors_in_variables,
            },
            "priors": {k: _describe(p) for k, p in zip(problem.names, problem.priors,
                                                         strict=True)},
            "prior_set": problem.prior_set,
            "prior_basis": problem.prior_basis.to_json(),
            "rate_window_s": problem.rate_window_s,
            "rate_window_choice": problem.rate_window_choice,
            "segment_means": self.segment_means,
            "block_means": self.block_means,
            "noise_choice": self.noise_choice or f"asked for: {problem.noise.name}",
            "convergence": {
                "point_estimate": point.message,
                "point_converged": point.converged,
                "starts": point.n_starts,
            },
            **self.checks.to_json(),
            "input_ranges": self.input_ranges,
            "effect_contributions_deg_h": self.effect_contributions(),
        }
        if self.noise_priors_from is not None:
            given = self.noise_priors_from
            out["noise"]["priors_from"] = {
                "source": given.source,
                "priors": {k: _describe(p) for k, p in zip(problem.names, problem.priors,
                                                           strict=True) if k in given.levels}}
        if post is not None:
            out["posterior"] = {k: post.summary[k] for k in names}
            out["noise"]["posterior"] = {k: post.summary[k] for k in noise_names}
            out["posterior_correlation"] = _correlation(post, problem.names, names)
            out["over_allowed_noise"] = (None if self.allowed_noise is None
                                         else self.allowed_noise.to_json())
            out["convergence"]["sampler"] = {
                "method": post.method,
                "move": post.move,
                "walkers": int(post.draws.shape[0]),
                "steps": post.n_steps,
                "burn": post.burn,
                "thin": post.thin,
                "draws_kept": int(post.draws.shape[0] * post.draws.shape[1]),
                "tau_steps": {k: float(t) for k, t in zip(problem.names, post.tau_steps,
                                                          strict=True)},
                "acceptance": post.acceptance,
                "converged": post.converged,
            }
        return out


def _correlation(post: Posterior, sampled: tuple[str, ...], names: tuple[str, ...]) -> dict:
    flat = post.draws.reshape(-1, len(sampled))[:, : len(names)]
    corr = np.corrcoef(flat, rowvar=False) if len(names) > 1 else np.ones((1, 1))
    return {a: {b: float(corr[i, j]) for j, b in enumerate(names)} for i, a in enumerate(names)}


def _describe(prior: Prior) -> str:
    return prior.describe()


def bench_result(problem: BenchProblem, point: PointEstimate, posterior: Posterior | None,
                 *, seed: int) -> BenchFit:
    """The frozen result of a bench fit, its self-checks (and how far its intervals rest on
    the noise levels' priors) computed first."""
    allowed = allowed_noise(problem, posterior, seed)
    return BenchFit(problem=problem, point=point, posterior=posterior, seed=seed,
                    checks=bench_checks(problem, point, posterior, allowed),
                    allowed_noise=allowed)
