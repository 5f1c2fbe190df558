"""Paper A's classical estimators and the reproduction and audit of both papers' tables.
"""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_classic": ["chi2_of", "magnetic_k", "setpoint_readings", "setpoint_table_fit"],
    "_repeatability": ["magnetic_repeatability", "repeatability_json"],
    "_reproduce": ["reproduce", "tables_markdown"],
})
