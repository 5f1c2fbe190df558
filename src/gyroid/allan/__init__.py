"""A static log's noise terms (IEEE 952) fitted on its Haar (Allan) variances: outliers found
first, each identifiable set of terms fitted (:class:`NoiseProblem`) and averaged by BIC
(:func:`fit_noise`, :class:`NoiseFit`), intervals stated against the log's overlapping
Allan deviation, and a unit's runs pooled (:func:`fit_unit_noise`).
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
