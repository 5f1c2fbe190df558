"""What every fit gives back (:class:`FitResult`: its self-checks and verdict, a summary for
the screen, its JSON record) and, for a fit of one problem, :class:`Fit` (the problem, its
mode, its posterior, the seed): the kinds of fit add their own parts."""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from gyroid.inference._check_report import CheckReport
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import AbstractProblem, PointEstimate


class FitResult(abc.ABC):
    """The base of every fit's frozen result (a dataclass with a ``checks`` field)."""

    checks: CheckReport

    @property
    def trustworthy(self) -> bool:
        """False when any error-level self-check failed (the command line's exit 3)."""
        return self.checks.trustworthy

    @abc.abstractmethod
    def summary(self) -> str:
        """A few lines for the screen: the estimates and the failed checks."""

    @abc.abstractmethod
    def to_json(self) -> dict:
        """The result's JSON record (docs/formats.md)."""


P = TypeVar("P", bound=AbstractProblem)


@dataclass(frozen=True, eq=False)
class Fit(FitResult, Generic[P]):
    """A fit of one problem (:func:`~gyroid.inference.fit`): the problem (its concrete kind
    ``P``, which a type checker follows: ``BenchFit`` is ``Fit[BenchProblem]``), its
    posterior mode, its posterior (None when only the mode was asked for), the seed the
    posterior and the checks drew with, and the self-checks. A kind's result adds its own
    fields after these."""

    problem: P = field(repr=False)
    point: PointEstimate = field(repr=False)
    posterior: Posterior | None = field(repr=False)
    seed: int
    checks: CheckReport = field(repr=False)

    @property
    def sampled(self) -> Posterior:
        """The posterior; ValueError for a fit of the mode alone."""
        if self.posterior is None:
            raise ValueError("this fit has no posterior (fitted with sample=False)")
        return self.posterior
