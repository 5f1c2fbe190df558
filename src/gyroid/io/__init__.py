"""Reading logs (CSV, .csv.gz, parquet; vendors' columns and units) and writing them, atomic
outputs, reading a fit back, paper A's printed tables.
"""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_arviz": ["arviz as load_arviz", "read_posterior", "write_netcdf"],
    "_fitted": ["FittedDrift"],
    "_logs": [
        "BENCH_COLUMNS", "BenchLog", "MeansOfBlocks", "contiguous_segments", "gap_threshold",
        "run_labels",
    ],
    "_stream": ["STREAM_ROWS", "parquet_rows", "stream_block_means"],
    "_bench_reader": ["bench_log_from_table", "load_bench_log"],
    "_log_writer": ["bench_log_text", "write_bench_log"],
    "_datasets": ["DATASETS", "data_home", "dataset_logs", "fetch", "missing"],
    "_outputs": ["atomic_write_text", "json_text", "output_dir", "output_lock"],
    "_paper_tables": [
        "paper_a_magnetic_coefficients", "paper_a_table_log", "paper_a_thermal_coefficients",
        "paper_a_thermal_table",
    ],
    "_roll_log": ["RollLog", "load_roll_log"],
    "_tables": ["log_kind", "read_header", "read_log_table"],
    "_units": ["ColumnMap", "parse_column_maps"],
})
