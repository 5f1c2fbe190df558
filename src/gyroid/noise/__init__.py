"""Noise models of drift logs: terms (white noise, flicker, a rate random walk, a
Gauss-Markov bias, the thermometer's rate error), each owning its levels, priors and states
in one block filter, and (the terms a static log's Allan variance shares, with quantisation,
a rate ramp and a prefilter's deficit) its Allan-variance shape; a model is a named tuple of
them (:class:`NoiseModel`), composed into one likelihood and one covariance of parts' means;
a fitted one (:class:`NoiseEstimate`); the registry by name (:func:`noise_model`)."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
