"""gyroid: distribution of paper B's dK for the fitted gyro (from the demo's propagation)."""

import json

import numpy as np
import paths

from gyroid.plotting import dk_distribution, save

result = json.loads(paths.data("propagate", "propagate.json").read_text())
samples = np.loadtxt(paths.data("propagate", "dk_samples.csv"), delimiter=",", skiprows=1)
save(dk_distribution(samples, result["closed_form"]["dK_eq7"], result["closed_form"]["dK_printed"]),
     paths.figure("gyroid_dk_distribution"), pdf=True)
