"""Where a tapped-column setup comes from: a TOML configuration plus overrides.

The package's configuration module ``bsrflow.io.config`` (``load_config(path)`` returning a
``Config`` with ``with_overrides(dict)`` and ``column_setup()``) is used when it is installed.
Until it exists, a small fallback reads the TOML file itself: every key, at the top level or in
any table, must be a :class:`~bsrflow.physics.column.ColumnSetup` field (or an alias from
:data:`ALIASES`) and the setup is ``ColumnSetup(**file_values | overrides)``.  Without a file the
fallback is ``ColumnSetup(**overrides)``.

:class:`SetupSource` hides which of the two is in use; it is small and picklable, so it can be
shipped to dask workers (the file is read once, where the sweep is launched).
"""

from __future__ import annotations

import dataclasses
import importlib
import os
import re
import tomllib
from dataclasses import dataclass, field

from ..physics.column import ColumnSetup

__all__ = ["ALIASES", "PARAMETER_INFO", "SetupSource", "canonical_name", "check_given_once", "check_no_run_outputs",
           "coerce_value", "parameter_info", "parse_value", "config_module"]

ALIASES = {"f": "frequency", "d": "diameter", "N": "n_spheres", "ppd": "points_per_diameter",
           "eps": "kernel_dissipation", "e": "restitution", "K": "stiffness", "g": "gravity", "taps": "n_taps",
           "start": "tap_start", "period": "tap_period"}
"""Short names accepted for ColumnSetup fields (``--param f=5,10`` is ``frequency``)."""

PARAMETER_INFO = {
    "n_spheres": ("1", "number of spheres N"),
    "diameter": ("m", "sphere diameter d"),
    "density": ("kg m-3", "sphere material density"),
    "stiffness": ("N m-1", "contact loading stiffness K"),
    "restitution": ("1", "DEM coefficient of restitution e"),
    "m0": ("kg", "kernel characteristic mass m0"),
    "kernel_dissipation": ("1", "kernel dissipation epsilon"),
    "gravity": ("m s-2", "gravitational acceleration g"),
    "a_over_d": ("1", "tap amplitude over diameter a/d"),
    "frequency": ("Hz", "tap frequency f"),
    "tap_start": ("s", "time of the first tap"),
    "n_taps": ("1", "number of taps"),
    "tap_period": ("s", "time between taps"),
    "t_end": ("s", "end time of the run"),
    "points_per_diameter": ("1", "grid points per diameter"),
    "scheme": ("", "scheme preset"),
    "save_every": ("s", "output interval"),
    "domain_height": ("m", "domain height"),
    "impulses": ("", "tap velocity jumps applied"),
    # scheme overrides of bsrflow.io.config ([numerics] cfl, stepper, rtol)
    "cfl": ("1", "Courant number"),
    "stepper": ("", "Runge-Kutta stepper"),
    "rtol": ("1", "relative tolerance of adaptive time stepping"),
}
"""(units, long_name) of each ColumnSetup field (and the config's scheme overrides), for netCDF
attributes."""

_FIELD_TYPES = {f.name: str(f.type) for f in dataclasses.fields(ColumnSetup)}
_INT = re.compile(r"^[+-]?\d+$")


def canonical_name(name: str) -> str:
    """The ColumnSetup field a parameter name refers to: aliases resolved, a table prefix
    (``tap.frequency``) dropped; unknown names are returned unchanged."""
    leaf = name.rsplit(".", 1)[-1]
    return ALIASES.get(leaf, leaf)


RUN_OUTPUT_KEYS = ("run.checkpoint_every", "run.write_state")
"""Config keys of `bsrflow run`'s files (checkpoints, the state in the netCDF file)."""


def check_no_run_outputs(who: str, named, config=None, config_path=None) -> None:
    """Refuse the options of `bsrflow run`'s files in a command that writes neither checkpoints nor
    a netCDF file (``who``: e.g. "sweep cases write"): ``named`` are (option, key) pairs of the
    command line (``--set run.write_state``, ``--param checkpoint_every``), ``config`` the
    command's :class:`bsrflow.io.config.Config` (or None), whose own values are refused too."""
    why = f"{who} no checkpoints and no netCDF files (options of `bsrflow run`)"
    for opt, key in named:
        if key.split(".")[-1] in [k.split(".")[-1] for k in RUN_OUTPUT_KEYS]:
            raise ValueError(f"{opt} {key}: {why}; leave it out")
    for key in RUN_OUTPUT_KEYS if config is not None else ():
        value = config[key]
        if value is not None and value is not False:
            shown = "true" if value is True else repr(value)
            raise ValueError(f"{key} = {shown} in {config_path}: {why}; remove it")


def check_given_once(given, key=canonical_name) -> dict:
    """Refuse a parameter given twice.

    ``given``: (option, name) pairs in the order they were given, e.g. ``("--set", "tap.f=5")``;
    a name may carry ``=VALUE``, and the parameter it names is ``key`` of the part before the
    ``=``.  At the first parameter named a second time, raises ValueError with one line naming
    the option and both spellings: ``--set frequency=6 is given twice (also as tap.f=5); give it
    once`` (the earlier option is named too when it differs).  Returns {parameter: (option,
    name)} of the pairs."""
    seen = {}
    for option, name in given:
        param = key(name.partition("=")[0].strip())
        if param in seen:
            first_option, first_name = seen[param]
            first = first_name if first_option == option else f"{first_option} {first_name}"
            also = "" if (first_option, first_name) == (option, name) else f" (also as {first})"
            raise ValueError(f"{option} {name} is given twice{also}; give it once")
        seen[param] = (option, name)
    return seen


def parameter_info(name: str) -> tuple[str, str]:
    """(units, long_name) for a parameter name ('' and the name itself if unknown)."""
    return PARAMETER_INFO.get(canonical_name(name), ("", name))


def parse_value(text: str):
    """A value given on the command line: int, float, true/false, or the word itself."""
    text = text.strip()
    if _INT.match(text):
        return int(text)
    try:
        return float(text)
    except ValueError:
        pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


def coerce_value(name: str, value):
    """``value`` converted to the type of the ColumnSetup field ``name`` refers to (int fields
    accept integral floats, bool fields 'true'/'false'); ValueError if it cannot be.  Values of
    unknown names are returned unchanged."""
    kind = _FIELD_TYPES.get(canonical_name(name))
    if kind is None:
        return value
    if kind == "int":
        try:
            f = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{name} = {value!r} is not an integer") from None
        if not f.is_integer():
            raise ValueError(f"{name} = {value!r} is not an integer")
        return int(f)
    if kind.startswith("float"):
        if value is None and "None" in kind:
            return None
        try:
            return float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{name} = {value!r} is not a number") from None
    if kind == "bool":
        if isinstance(value, str) and value.lower() in ("true", "yes", "1", "false", "no", "0"):
            return value.lower() in ("true", "yes", "1")
        if isinstance(value, (bool, int)) and value in (0, 1):
            return bool(value)
        raise ValueError(f"{name} = {value!r} is not true or false")
    return str(value)


def config_module():
    """``bsrflow.io.config`` if it exists and provides ``load_config``, else None."""
    try:
        mod = importlib.import_module("bsrflow.io.config")
    except ImportError:
        return None
    return mod if hasattr(mod, "load_config") else None


def _toml_items(data: dict, prefix=""):
    """(dotted key, value) of every non-table value of a parsed TOML file, tables flattened."""
    for key, value in data.items():
        if isinstance(value, dict):
            yield from _toml_items(value, prefix + key + ".")
        else:
            yield prefix + key, value


def _flatten_toml(data: dict, path: str) -> dict:
    items = list(_toml_items(data))
    for key, _value in items:
        if canonical_name(key) not in _FIELD_TYPES:
            raise ValueError(f"{path}: key {key!r} is not a column parameter (known: {', '.join(_FIELD_TYPES)})")
    check_given_once((f"{path}: key", key) for key, _value in items)
    return {canonical_name(key): coerce_value(canonical_name(key), value) for key, value in items}


@dataclass
class SetupSource:
    """A base configuration from which ColumnSetups are made with overrides.

    Attributes: ``path`` the TOML file (or None: the ColumnSetup defaults); ``config`` the
    ``bsrflow.io.config`` Config object when that module exists; ``values`` the fallback's
    ColumnSetup keyword arguments read from the file; ``text`` the file's text (kept for
    provenance in outputs); ``fixed`` overrides applied under the per-call ones (``--set``).
    """

    path: str | None = None
    config: object | None = None
    values: dict = field(default_factory=dict)
    text: str = ""
    fixed: dict = field(default_factory=dict)

    def with_fixed(self, fixed: dict) -> "SetupSource":
        """A copy whose every setup also gets the overrides ``fixed`` (under the per-call ones)."""
        return dataclasses.replace(self, fixed=self.fixed | dict(fixed))

    @classmethod
    def load(cls, path=None, use_config_module: bool = True) -> "SetupSource":
        """Read ``path`` (TOML) with ``bsrflow.io.config.load_config`` if available (and
        ``use_config_module``), else with the fallback reader.  ``path=None``: the config
        module's defaults (``Config.default()``, what ``bsrflow init`` writes) if available, else
        the ColumnSetup defaults."""
        mod = config_module() if use_config_module else None
        if path is None:
            default = getattr(getattr(mod, "Config", None), "default", None)
            if default is None:
                return cls()
            cfg = default()
            return cls(config=cfg, text=cfg.to_toml() if hasattr(cfg, "to_toml") else "")
        path = os.fspath(path)
        if not path:
            raise ValueError("the configuration file name is empty; give a TOML file")
        if not os.path.exists(path):
            raise FileNotFoundError(f"{path}: no such configuration file")
        if os.path.isdir(path):
            raise ValueError(f"{path}: is a directory, not a configuration file")
        with open(path, "rb") as fh:
            raw = fh.read()
        text = raw.decode("utf-8", errors="replace")
        if mod is not None:
            return cls(path=path, config=mod.load_config(path), text=text)
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML: {exc}") from None
        return cls(path=path, values=_flatten_toml(data, path), text=text)

    @property
    def uses_config_module(self) -> bool:
        return self.config is not None

    def _overrides(self, overrides: dict) -> dict:
        """Overrides with aliases resolved to ColumnSetup field names and values coerced."""
        out = {}
        for name, value in (overrides or {}).items():
            key = canonical_name(name) if (name in ALIASES or self.config is None) else name
            out[key] = coerce_value(name, value)
        return out

    def column_setup(self, overrides: dict | None = None) -> ColumnSetup:
        """The ColumnSetup for these overrides {name: value} (SI units).  Raises ValueError for
        values outside the valid ranges (the config's or ColumnSetup's checks)."""
        return self.setup_and_scheme(overrides)[0]

    def setup_and_scheme(self, overrides: dict | None = None):
        """(ColumnSetup, Scheme or None) for these overrides.  The scheme is the config's
        ``Config.scheme()`` (the preset with its cfl/stepper/rtol overrides) when the config
        module provides it; None means the preset named by ``setup.scheme``."""
        ov = self._overrides(self.fixed | dict(overrides or {}))
        if self.config is not None:
            cfg = self.config.with_overrides(ov)
            setup = cfg.column_setup()
            packing = getattr(setup, "kernel_name", "seed") == "packing"     # its schemes are the formulation's
            scheme = cfg.scheme() if callable(getattr(cfg, "scheme", None)) and not packing else None
            return setup, scheme
        unknown = [k for k in ov if k not in _FIELD_TYPES]
        if unknown:
            raise ValueError(f"unknown parameter {unknown[0]!r}")
        return ColumnSetup(**(self.values | ov)), None

    def check_names(self, names_values: dict) -> None:
        """Raise ValueError if a parameter name is unknown.  ``names_values``: {name: a sample
        value}.  With the config module: ``Config.resolve_key`` decides if it exists; otherwise a
        name is unknown when ``with_overrides`` rejects it with a KeyError/AttributeError/TypeError
        or a message containing "unknown".  Errors about the value itself are left to the cases."""
        for name, value in (self.fixed | dict(names_values)).items():
            if self.config is None:
                if canonical_name(name) not in _FIELD_TYPES:
                    raise ValueError(f"unknown parameter {name!r} (known: {', '.join(_FIELD_TYPES)}; "
                                     f"aliases: {', '.join(f'{k}={v}' for k, v in ALIASES.items())})")
                continue
            resolve = getattr(type(self.config), "resolve_key", None)
            if resolve is not None:
                key = next(iter(self._overrides({name: value})))
                try:
                    resolve(key)
                except (KeyError, ValueError) as exc:
                    raise ValueError(f"unknown parameter {name!r}: {_one_line(exc)}") from None
                continue
            try:
                self.config.with_overrides(self._overrides({name: value}))
            except (KeyError, AttributeError, TypeError) as exc:
                raise ValueError(f"unknown parameter {name!r}: {exc}") from None
            except ValueError as exc:
                if "unknown" in str(exc).lower():
                    raise ValueError(f"unknown parameter {name!r}: {exc}") from None


def _one_line(exc) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
