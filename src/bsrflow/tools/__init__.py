"""Command-line tools built on the package: ``bsrflow plot`` (figures from an output netCDF
file), ``bsrflow sweep`` (parameter sweeps on dask.distributed) and the adapter between TOML
configurations and :class:`bsrflow.physics.column.ColumnSetup` they share with
``bsrflow compare-dump``."""
