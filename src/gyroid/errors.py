"""The one exception type gyroid raises for bad input."""

from __future__ import annotations


class GyroidInputError(ValueError):
    """Input that gyroid refuses, with a message naming the row or column and what to do.

    The command line prints the message alone (no traceback) and exits with code 2.
    """


class UntrustworthyResult(Exception):
    """Raised by a command after it wrote a result whose self-checks failed at error level;
    the command line exits with code 3 (the failed checks are already printed)."""
