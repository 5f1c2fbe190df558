"""Noise models of drift logs: an abstract :class:`NoiseModel` with final kinds (white,
white + Gauss-Markov, IEEE 952 white + flicker + rate random walk), each owning its levels,
priors, likelihood (the filters live here) and the covariance of parts' means; a fitted one
(:class:`NoiseEstimate`); the registry by name (:func:`noise_model`)."""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_base": ["NoiseEstimate", "NoiseModel", "RowClock", "RowFilter", "predictive_level"],
    "_kinds": ["GaussMarkov", "Ieee952", "NOISE_MODELS", "White", "noise_model",
               "recorded_model"],
})
