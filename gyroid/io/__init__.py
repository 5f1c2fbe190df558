"""Reading logs (CSV, .csv.gz, parquet; vendors' columns and units), writing each step's files
atomically, reading a fit back.
"""
