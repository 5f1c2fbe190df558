"""Public names of :mod:`gyroid.inference` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._batching import problem_batcher as problem_batcher
from ._check_report import Check as Check
from ._check_report import CheckReport as CheckReport
from ._check_report import FitEvidence as FitEvidence
from ._checks import fit_checks as fit_checks
from ._checks import goodness_of_fit as goodness_of_fit
from ._checks import identifiability as identifiability
from ._checks import point_vs_posterior as point_vs_posterior
from ._checks import prior_data_conflict as prior_data_conflict
from ._emcee import Emcee as Emcee
from ._fit import fit as fit
from ._importance import Importance as Importance
from ._nuts import Nuts as Nuts
from ._posterior import Posterior as Posterior
from ._posterior import interval_summary as interval_summary
from ._posterior import summarise_draws as summarise_draws
from ._problem import AbstractProblem as AbstractProblem
from ._problem import AbstractSampler as AbstractSampler
from ._problem import PointEstimate as PointEstimate
from ._residual_checks import block_variance_ratios as block_variance_ratios
from ._residual_checks import outliers as outliers
from ._residual_checks import residual_whiteness as residual_whiteness
from ._residual_checks import segment_variance_ratio as segment_variance_ratio
from ._result import FitResult as FitResult
