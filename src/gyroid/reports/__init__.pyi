"""Public names of :mod:`gyroid.reports` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._reproduction import write_reproduction as write_reproduction
from ._write import write as write
from ._write import write_compensated_csv as write_compensated_csv
