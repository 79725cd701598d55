"""Input/output: TOML configs (:mod:`.config`), netCDF output written as a run goes
(:mod:`.netcdf`), checkpoints (:mod:`.checkpoint`), running a config (:mod:`.runner`), and the
``bsrflow init`` / ``bsrflow run`` commands (:mod:`.commands`)."""

from .config import Config, ConfigError, default_config_text, load_config
from .netcdf import SCHEMA, NetCDFWriter
from .runner import RunOutcome, run_config

__all__ = ["Config", "ConfigError", "load_config", "default_config_text", "NetCDFWriter", "SCHEMA",
           "run_config", "RunOutcome"]
