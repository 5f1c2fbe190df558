"""ArviZ, imported on first use and without its refactor announcement (a FutureWarning on
import), and netCDF files written and read."""

from __future__ import annotations

import warnings

import numpy as np

from gyroid.errors import GyroidInputError


def load_arviz():
    """The arviz module (imported here: it costs seconds, and only storage needs it)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=FutureWarning)
        import arviz as az
    return az


def write_netcdf(idata, path) -> None:
    """Write an InferenceData without zlib: the observed log in it (10^7 rows of float
    noise) does not compress, and compressing it took 6 s of a 10^7-row fit's 30."""
    idata.to_netcdf(str(path), compress=False)


def read_posterior(path) -> dict[str, np.ndarray]:
    """The draws in the posterior group of a netCDF file gyroid wrote, by variable name
    (arrays of chain x draw x ...). Read with h5py: a netCDF-4 file is HDF5, and ArviZ with
    xarray and dask took most of a second to import for it."""
    import h5py

    with h5py.File(path, "r") as handle:
        group = handle.get("posterior")
        if not isinstance(group, h5py.Group):
            raise GyroidInputError(f"{path} has no posterior group: it is not a posterior.nc "
                                   "gyroid wrote")
        return {name: np.asarray(data[...]) for name, data in group.items()
                if isinstance(data, h5py.Dataset)
                and data.attrs.get("CLASS") != b"DIMENSION_SCALE"}
