"""ArviZ, imported on first use and without its refactor announcement (a FutureWarning on
import), and netCDF files written and read."""

from __future__ import annotations

import warnings


def arviz():
    """The arviz module (imported here: it costs seconds, and only storage needs it)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=FutureWarning)
        import arviz as az
    return az


def write_netcdf(idata, path) -> None:
    """Write an InferenceData without zlib: the observed log in it (10^7 rows of float
    noise) does not compress, and compressing it took 6 s of a 10^7-row fit's 30."""
    idata.to_netcdf(str(path), compress=False)


def read_posterior(path):
    """The posterior group of a netCDF file gyroid wrote."""
    return arviz().from_netcdf(str(path)).posterior
