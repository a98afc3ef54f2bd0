"""Packaged data: the paper's M tables (Tables II-IV) as CSV files."""
