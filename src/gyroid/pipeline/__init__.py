"""What a command does, without the printing: read, fit and write one log
(:func:`fit_file` with :class:`FitOptions`), many logs on Dask (:func:`run_batch`), the
whole study on built-in data (:func:`run_demo`). The command line calls these."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
