"""Paper A's classical estimators and the reproduction and audit of both papers' tables.
"""

from gyroid.papers._classic import (
    chi2_of,
    magnetic_k,
    setpoint_readings,
    setpoint_table_fit,
)
from gyroid.papers._repeatability import (
    magnetic_repeatability,
    repeatability_json,
)
from gyroid.papers._reproduce import (
    reproduce,
    tables_markdown,
)

__all__ = [
    "chi2_of",
    "magnetic_k",
    "magnetic_repeatability",
    "repeatability_json",
    "reproduce",
    "setpoint_readings",
    "setpoint_table_fit",
    "tables_markdown",
]
