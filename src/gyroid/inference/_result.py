"""What every fit gives back (:class:`FitResult`): its self-checks and verdict, a summary
for the screen, and its JSON record; the kinds of fit add their own parts."""

from __future__ import annotations

import abc

from gyroid.inference._check_report import CheckReport


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
