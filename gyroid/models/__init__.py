"""What a gyro is made of: the effect registries (bench and roll), the drift and roll-loop
physics, derived inputs, priors.
"""
