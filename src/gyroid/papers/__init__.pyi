"""Public names of :mod:`gyroid.papers` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._classic import chi2_of as chi2_of
from ._classic import magnetic_k as magnetic_k
from ._classic import setpoint_readings as setpoint_readings
from ._classic import setpoint_table_fit as setpoint_table_fit
from ._repeatability import magnetic_repeatability as magnetic_repeatability
from ._repeatability import repeatability_json as repeatability_json
from ._reproduce import reproduce as reproduce
from ._reproduce import tables_markdown as tables_markdown
