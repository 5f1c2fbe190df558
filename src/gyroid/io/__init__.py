"""Reading logs (CSV, .csv.gz, parquet; vendors' columns and units) and writing them, atomic
outputs, reading a fit back, paper A's printed tables.
"""

from gyroid.io._fitted import (
    FittedDrift,
)
from gyroid.io._logs import (
    BENCH_COLUMNS,
    BenchLog,
    bench_log_text,
    contiguous_segments,
    load_bench_log,
    run_labels,
    write_bench_log,
)
from gyroid.io._outputs import (
    atomic_write_text,
    json_text,
    output_dir,
)
from gyroid.io._paper_tables import (
    paper_a_magnetic_coefficients,
    paper_a_table_log,
    paper_a_thermal_coefficients,
    paper_a_thermal_table,
)
from gyroid.io._roll_log import (
    RollLog,
    load_roll_log,
)
from gyroid.io._tables import (
    log_kind,
    read_header,
    read_log_table,
)
from gyroid.io._units import (
    ColumnMap,
    parse_column_maps,
)

__all__ = [
    "BENCH_COLUMNS",
    "BenchLog",
    "ColumnMap",
    "FittedDrift",
    "RollLog",
    "atomic_write_text",
    "bench_log_text",
    "contiguous_segments",
    "json_text",
    "load_bench_log",
    "load_roll_log",
    "log_kind",
    "output_dir",
    "paper_a_magnetic_coefficients",
    "paper_a_table_log",
    "paper_a_thermal_coefficients",
    "paper_a_thermal_table",
    "parse_column_maps",
    "read_header",
    "read_log_table",
    "run_labels",
    "write_bench_log",
]
