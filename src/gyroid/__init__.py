"""gyroid: Bayesian identification of gyroscope error models.

Paper A's fibre-optic-gyro drift as a sum of named effects (temperature, its rate, magnetic
field, and candidate effects) and paper B's roll-gyro scale-factor correction loop: benches
and flights simulated with known truth, fits that check themselves, compensation,
propagation to the correction coefficient's error, and the discrepancy workflow. All models
run in JAX with float64.

``import gyroid`` loads nothing heavy and changes no global setting: each public name is
imported on first use, from the subpackage that holds it (``gyroid.models``,
``gyroid.io``, ``gyroid.simulation``, ``gyroid.inference``, ``gyroid.workflows``,
``gyroid.reports``, ...). Using a computing name turns on JAX's float64;
:func:`configure` also turns on the persistent compilation cache.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

import lazy_loader

#: Each public name and the subpackage it is imported from on first use: __init__.pyi.
__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)

try:
    __version__ = version("gyroid")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
