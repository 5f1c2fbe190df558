"""Reading logs (CSV, .csv.gz, parquet; vendors' columns and units) and writing them, atomic
outputs, reading a fit back, paper A's printed tables.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
