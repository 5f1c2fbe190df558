"""Fitting: one abstract problem (:class:`AbstractProblem`) with three final kinds (a bench
log's drift model, paper B's loop on a roll log, a pooled lot of runs), one :func:`fit`,
interchangeable samplers (:class:`Importance`, :class:`Emcee`, :class:`Nuts`), frozen
results, and the self-checks every fit passes through.
"""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_problem": ["AbstractProblem", "AbstractSampler", "PointEstimate"],
    "_fit": ["fit"],
    "_result": ["FitResult"],
    "_posterior": ["Posterior", "interval_summary", "summarise_draws"],
    "_emcee": ["Emcee"],
    "_nuts": ["Nuts"],
    "_importance": ["Importance"],
    "_bench_problem": ["BenchProblem"],
    "_bench_density": ["BenchDensity"],
    "_bench_fit": ["fit_log"],
    "_bench_result": ["BenchFit"],
    "_roll_problem": ["RollProblem"],
    "_roll_density": ["ALL_PARAMETERS"],
    "_roll_fit": ["fit_roll_log"],
    "_roll_result": ["RollFit"],
    "_pool_problem": ["PoolProblem"],
    "_noise_problem": ["NoiseProblem"],
    "_noise_fit": ["NoiseFit", "fit_noise"],
    "_noise_model_fit": ["NoiseModelFit"],
    "_noise_unit": ["UnitNoise", "fit_unit_noise"],
    "_pool_fit": ["fit_pool", "pool_estimates", "pool_problem"],
    "_pool_result": ["PoolFit"],
    "_rate_window": ["choose_rate_window"],
    "_check_report": ["Check", "CheckReport", "FitEvidence"],
    "_checks": [
        "fit_checks", "goodness_of_fit", "identifiability", "point_vs_posterior",
        "prior_data_conflict",
    ],
    "_residual_checks": [
        "block_variance_ratios", "outliers", "residual_whiteness", "segment_variance_ratio",
    ],
    "_batching": ["problem_batcher"],
    "_starts": ["START_MULTIPLES", "grid_points", "start_grid"],
})
