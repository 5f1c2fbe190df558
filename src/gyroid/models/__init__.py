"""What a gyro is made of: the effect registries (bench and roll), the drift and roll-loop
physics, derived inputs, priors.

Importing this package (as every computing part of gyroid does) turns on JAX's float64:
see :mod:`gyroid._config`.
"""

import lazy_loader

from gyroid._config import enable_float64 as _enable_float64

_enable_float64()

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
