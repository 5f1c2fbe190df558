"""Paper A's benches and paper B's flights simulated with known truth, and gyro noise.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
