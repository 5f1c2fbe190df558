"""ArviZ, imported once without its refactor announcement (a FutureWarning on import)."""

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", category=FutureWarning, module="arviz")
    import arviz

__all__ = ["arviz", "write_netcdf"]

# An emcee ensemble stored as chains has more walkers than kept draws per walker; ArviZ's
# shape heuristic then warns although the (chain, draw) layout is right.
warnings.filterwarnings("ignore", message="More chains .* than draws", module="arviz")


def write_netcdf(idata, path) -> None:
    """Write an InferenceData without zlib: the observed log in it (10^7 rows of float
    noise) does not compress, and compressing it took 6 s of a 10^7-row fit's 30."""
    idata.to_netcdf(str(path), compress=False)
