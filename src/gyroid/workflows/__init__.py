"""What a user runs on a fit or a log: discrepancy (bench and roll, one loop), compensation,
propagation to dK, sensitivity, Allan deviation.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
