"""gyroid: posterior pair plot of the thermal coefficients (from the demo's posterior.nc)."""

import json

import numpy as np
import paths

from gyroid.io import load_arviz
from gyroid.models import PARAMETERS
from gyroid.plotting import pair_plot, save

az = load_arviz()

fit = json.loads(paths.data("thermal", "fit", "fit.json").read_text())
truth = json.loads(paths.data("thermal", "truth.json").read_text())["parameters"]
posterior = az.from_netcdf(str(paths.data("thermal", "fit", "posterior.nc"))).posterior
names = list(fit["point"])
draws = np.column_stack([np.asarray(posterior[n]).reshape(-1) for n in names])
units = {n: PARAMETERS[n].unit for n in names}
save(pair_plot(draws, names, units, truth), paths.figure("gyroid_posterior_pair"), pdf=True)
