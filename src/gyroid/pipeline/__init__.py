"""What a command does, without the printing: read, fit and write one log
(:func:`fit_file` with :class:`FitOptions`), many logs on Dask (:func:`run_batch`), the
whole study on built-in data (:func:`run_demo`). The command line calls these."""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_fit_file": ["FitOptions", "fit_file"],
    "_batch": ["BatchResult", "LogOutcome", "run_batch"],
    "_demo": ["run_demo"],
    "_demo_study": ["DemoSize"],
})
