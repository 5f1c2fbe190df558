"""Noise models of drift logs: terms (white noise, flicker, a rate random walk, a
Gauss-Markov bias, the thermometer's rate error), each owning its levels, priors and states
in one block filter, and (the terms a static log's Allan variance shares, with quantisation,
a rate ramp and a prefilter's deficit) its Allan-variance shape; a model is a named tuple of
them (:class:`NoiseModel`), composed into one likelihood and one covariance of parts' means;
a fitted one (:class:`NoiseEstimate`); the registry by name (:func:`noise_model`)."""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_allan_terms": ["AbstractAllanTerm", "Prefilter", "Quantisation", "RateRamp"],
    "_base": ["RowClock", "predictive_level"],
    "_estimate": ["NoiseEstimate"],
    "_level_priors": ["priors_from_noise"],
    "_model": ["DEFAULT_NOISE", "NOISE_MODELS", "NoiseModel", "RowFilter", "noise_choice",
               "noise_model", "recorded_model"],
    "_terms": ["AbstractNoiseTerm", "AbstractWhiteTerm", "AngleRandomWalk", "Flicker",
               "GaussMarkovBias", "RateError", "RateRandomWalk", "SampleWhite",
               "STATIC_TERMS"],
})
