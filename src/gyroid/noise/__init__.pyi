"""Public names of :mod:`gyroid.noise` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._allan_terms import AbstractAllanTerm as AbstractAllanTerm
from ._allan_terms import Prefilter as Prefilter
from ._allan_terms import Quantisation as Quantisation
from ._allan_terms import RateRamp as RateRamp
from ._base import RowClock as RowClock
from ._base import predictive_level as predictive_level
from ._estimate import NoiseEstimate as NoiseEstimate
from ._level_priors import priors_from_noise as priors_from_noise
from ._model import DEFAULT_NOISE as DEFAULT_NOISE
from ._model import NOISE_MODELS as NOISE_MODELS
from ._model import NoiseModel as NoiseModel
from ._model import noise_choice as noise_choice
from ._model import noise_model as noise_model
from ._model import recorded_model as recorded_model
from ._row_filter import RowFilter as RowFilter
from ._terms import STATIC_TERMS as STATIC_TERMS
from ._terms import AbstractNoiseTerm as AbstractNoiseTerm
from ._terms import AbstractWhiteTerm as AbstractWhiteTerm
from ._terms import AngleRandomWalk as AngleRandomWalk
from ._terms import Flicker as Flicker
from ._terms import GaussMarkovBias as GaussMarkovBias
from ._terms import RateError as RateError
from ._terms import RateRandomWalk as RateRandomWalk
from ._terms import SampleWhite as SampleWhite
