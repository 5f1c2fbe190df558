"""ArviZ, imported once without its refactor announcement (a FutureWarning on import)."""

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", category=FutureWarning, module="arviz")
    import arviz

__all__ = ["arviz"]

# An emcee ensemble stored as chains has more walkers than kept draws per walker; ArviZ's
# shape heuristic then warns although the (chain, draw) layout is right.
warnings.filterwarnings("ignore", message="More chains .* than draws", module="arviz")
