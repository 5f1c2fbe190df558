"""Public names of :mod:`gyroid.allan` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._fit import NoiseFit as NoiseFit
from ._fit import fit_noise as fit_noise
from ._model_fit import NoiseModelFit as NoiseModelFit
from ._problem import NoiseProblem as NoiseProblem
from ._unit import UnitNoise as UnitNoise
from ._unit import fit_unit_noise as fit_unit_noise
