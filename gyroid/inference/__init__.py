"""Likelihoods (one Kalman filter), point estimates, posteriors (emcee) and the self-checks
every fit passes through.
"""
