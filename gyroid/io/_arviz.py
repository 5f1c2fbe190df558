"""ArviZ, imported once without its refactor announcement (a FutureWarning on import)."""

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", category=FutureWarning, module="arviz")
    import arviz

__all__ = ["arviz"]
