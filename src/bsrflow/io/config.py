"""TOML configuration of a tapped-column run (``bsrflow init`` writes one, ``bsrflow run`` reads it).

A configuration has four tables, every key optional (defaults below, SI units)::

    [column]    n_spheres, diameter [m], density [kg/m3], stiffness [N/m], restitution,
                m0 [kg], kernel_dissipation, gravity [m/s2]
    [tap]       a_over_d, frequency [Hz], start [s], n_taps, period [s], impulses
    [run]       t_end [s], save_every [s], checkpoint_every [s] (absent: about every 0.1 s;
                0: no checkpoints), write_state (packing: the state fields in the file too)
    [numerics]  scheme ("seed" | "accurate"), points_per_diameter, and the optional
                overrides cfl, stepper, rtol, atol [m/s, kg/m], domain_height [m]

The defaults are those of :class:`bsrflow.physics.column.ColumnSetup` except the continuum
constants m0 = 406 kg and kernel_dissipation = 0.9, the calibration that ``make demo``
(``bsrflow demo``) measured on the single tap a/d = 0.75 before a change of summation order in
the fast integral; the calibration of today's demo (a compass search since 2026-12-06) finds
(409 kg, 0.896) with about the same residual, the fit being flat at the level of round-off
(docs/seed-kernel.md) (the seed's printed m0 = 22 kg makes the resting column expand).

Every field is validated before a run: :func:`load_config` / :meth:`Config.from_dict` raise
:class:`ConfigError` (a ``ValueError``) whose message is one line starting with the dotted field
name, e.g. ``tap.a_over_d: -1.0 is outside the valid range [0, 20]``.

API::

    cfg = load_config("column.toml")               # validated, defaults filled
    cfg = cfg.with_overrides({"a_over_d": 0.5, "numerics.scheme": "accurate"})
    cfg.tap.a_over_d, cfg["tap.a_over_d"]           # 0.5
    setup, scheme = cfg.column_setup(), cfg.scheme()
    text = cfg.to_toml()                            # commented TOML that loads back to cfg
    default_config_text()                           # what `bsrflow init` writes
"""

from __future__ import annotations

import difflib
import math
import os
import re
import tomllib
from dataclasses import dataclass
from typing import Any, Mapping

__all__ = ["Config", "ConfigError", "load_config", "default_config_text", "saved_config", "parse_override",
           "field_range", "CFL_LIMITS", "FIELDS"]


class ConfigError(ValueError):
    """An invalid configuration.  ``str(err)`` is one line ``<field>: <problem>``; ``field`` is
    the dotted name (``tap.a_over_d``) or, for file-level problems, the file path."""

    def __init__(self, field: str, problem: str, value: Any = None, valid: str | None = None):
        self.field = field
        self.value = value
        self.valid = valid
        one_line = " ".join(str(problem).split())
        super().__init__(f"{field}: {one_line}")


# -- stability limits and the snapshot cap: in bsrflow.numerics.limits (also used by the API) --
from ..numerics.limits import CFL_LIMITS, MAX_SNAPSHOTS as _MAX_SNAPSHOTS, cfl_limit as _cfl_limit  # noqa: E402

_STEPPERS = ("euler", "heun", "kutta3", "rk3", "rk4", "bs32", "rk4_0.4_0.25")
_EMBEDDED = ("heun", "kutta3", "rk3", "bs32")
_SCHEMES = ("seed", "accurate")
_MAX_CHECKPOINTS = 100_000
_AUTO_CHECKPOINT = 0.1          # [s] default checkpoint interval (rounded up to whole snapshots)
_AUTO_CHECKPOINTS = 1000        # at most this many default checkpoints per run
_MAX_CELLS = 2_000_000
_MAX_HEIGHT = 1e4     # [m], the largest domain


# -- the fields ------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Field:
    table: str
    key: str
    kind: str                      # "int", "float", "bool", "str"
    default: Any                   # None: optional, absent by default
    doc: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple = ()

    @property
    def name(self) -> str:
        return f"{self.table}.{self.key}"

    def range_text(self, hi: float | None = None) -> str:
        if self.kind == "bool":
            return "true or false"
        if self.kind == "str":
            return "one of " + ", ".join(f'"{c}"' for c in self.choices)
        hi = self.hi if hi is None else hi
        lo_b = "(" if self.lo_open else "["
        hi_b = ")" if self.hi_open else "]"
        txt = f"{lo_b}{_num(self.lo)}, {_num(hi)}{')' if hi is None else hi_b}"
        if self.kind == "int":
            txt += " (integers)"
        return txt + (f" {self.unit}" if self.unit else "")

    def in_range(self, v: float, hi: float | None = None) -> bool:
        hi = self.hi if hi is None else hi
        if not math.isfinite(v):
            return False
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return False
        if hi is not None and (v >= hi if self.hi_open else v > hi):
            return False
        return True


def _num(v) -> str:
    if v is None:
        return "inf"
    return f"{v:g}"


_CAL = ("406 kg: the calibration that `make demo` measured on the single tap a/d = 0.75 (seed scheme; "
        "today's demo finds 409 kg, 0.896 with about the same residual: the fit is flat, docs/seed-kernel.md; the seed prints "
        "22 kg, with which the resting column expands)")

FIELDS: tuple[_Field, ...] = (
    # [column] -- the spheres and the continuum constants
    _Field("column", "n_spheres", "int", 20, "number of spheres stacked on the floor", "", 2, 100000),
    _Field("column", "diameter", "float", 0.022,
           "sphere diameter d (2.2 cm reproduces the seed's DEM heights; the seed never states d)",
           "m", 1e-6, 10),
    _Field("column", "density", "float", 1200.0, "density of the sphere material", "kg/m3", 1, 1e5),
    _Field("column", "stiffness", "float", 1.366e7, "contact stiffness K (DEM loading; the kernel's K; the "
           "packing kernel also needs the column's weight to overlap its bottom contact by at most 0.05 d and "
           "at most 1e9 steps, the seed kernel its column settled under its weight at least 1 d tall, K >= "
           "3 m0 g/(2 N d); each names the range at the settings when not)", "N/m", 1e-3, 1e12),
    _Field("column", "restitution", "float", 0.9, "coefficient of restitution e of the DEM contacts "
           "(and of the packing law; the seed kernel's continuum does not use it)", "", 0.01, 1),
    _Field("column", "m0", "float", 406.0,
           "continuum characteristic mass m0 of the kernel, lambda = K/(m m0); default " + _CAL,
           "kg", 1e-12, 1e12),
    _Field("column", "kernel_dissipation", "float", 0.9,
           "dissipation epsilon of the continuum kernel (not the restitution: e^2 = (1-eps)/(1+eps)); "
           "default 0.9, calibrated together with m0 by `make demo` on a/d = 0.75", "", 0, 1,
           hi_open=True),
    _Field("column", "gravity", "float", 9.81, "gravitational acceleration g", "m/s2", 1e-3, 1e4),
    # [model] -- the interaction
    _Field("model", "kernel", "str", "seed", "interaction: \"seed\" (the seed's kernel (4.6) with m0 "
           "and kernel_dissipation, solved by numerics.scheme) or \"packing\" (the contact law's "
           "continuum: only K, e, d, density, N and g enter; m0, kernel_dissipation, a scheme other "
           "than \"seed\", stepper, rtol and atol are refused with it)", choices=("seed", "packing")),
    _Field("model", "stiffness_factor", "float", 1.0, "packing only: the contact stiffness used is K "
           "times this factor (1: the DEM's own; smaller runs faster at a documented cost in "
           "accuracy)", "", 0, 1, lo_open=True),
    _Field("model", "range_over_d", "float", None, "packing only: the interaction range R in sphere "
           "diameters (default, when absent: 1, the nonlocal interaction over one diameter, in both "
           "formulations; 0: its local limit; the eulerian formulation runs R > 0 on a staggered grid with a "
           "tracked surface, R = 0 as finite volumes, docs/model.md)", "", 0, 4),
    _Field("model", "stiffness_mach", "float", 0.0, "packing only: if > 0, choose the stiffness "
           "factor so that the impact Mach number 3 a w / c is this (0.01: top maximum within 1 % and "
           "mass-centre RMS within 0.15 d of the true stiffness's (R = d, both formulations), 1.5 % and 0.25 d "
           "(lagrangian, local), 1 % and 1.2 d (eulerian, local), measured; 0: off)", "", 0, 1),
    # [tap] -- half-sine displacement pulses of the floor
    _Field("tap", "a_over_d", "float", 0.75, "tap amplitude a in units of the sphere diameter "
           "(0: no tap)", "", 0, 20),
    _Field("tap", "frequency", "float", 10.0, "tap frequency f; one tap lasts 1/(2f)", "Hz", 1e-3, 1e4),
    _Field("tap", "start", "float", 0.4, "time of the first tap (the column settles before it)", "s",
           0, 1e5),
    _Field("tap", "n_taps", "int", 1, "number of taps (0: no tap)", "", 0, 1_000_000),
    _Field("tap", "period", "float", 0.6, "time between tap starts; at least the tap duration "
           "1/(2f) when n_taps > 1", "s", 0, 1e5, lo_open=True),
    _Field("tap", "impulses", "bool", True, "apply the velocity jumps of the displacement pulse "
           "(true, correct) or only its smooth part a w^2 sin wt as printed in the seed (false)"),
    # [run]
    _Field("run", "t_end", "float", 1.3, "final time", "s", 1e-9, 1e5),
    _Field("run", "save_every", "float", 0.005, "time between snapshots written to the netCDF file "
           "(at most t_end)", "s", 1e-9, None),
    _Field("run", "checkpoint_every", "float", None, "simulated time between checkpoints "
           "<out>.ckpt that `bsrflow run --resume` continues from (default, when absent: every "
           f"{_AUTO_CHECKPOINT:g} s rounded up to a whole number of snapshots, at most "
           f"{_AUTO_CHECKPOINTS} per run; 0: no checkpoints; at most t_end)", "s", 0, None),
    _Field("run", "write_state", "bool", False, "packing only: also write the discretisation's state "
           "fields to the netCDF file at every snapshot, as state_<name> with units (eulerian, R = d: cell_mass, "
           "velocity on the faces, the bonds' delta_max and delta_max_image, surface; eulerian, range_over_d = 0: "
           "rho, momentum, rho_delta_max on the grid; lagrangian: the material points' position, velocity and bond "
           "histories delta_max); the same named fields as its checkpoints"),
    # [numerics]
    _Field("numerics", "scheme", "str", "seed", "scheme preset: \"seed\" (Kutta RK3 + moving "
           "average every step, CFL 0.5) or \"accurate\" (four-stage RK4 rk4_0.4_0.25, CFL 0.2, "
           "sensor-switched dissipation)",
           choices=_SCHEMES),
    _Field("numerics", "formulation", "str", None, "\"eulerian\" (fields on the grid: for the packing kernel a staggered Lagrange-remap "
           "form with range_over_d > 0, finite volumes with 0) or "
           "\"lagrangian\" (material points, density by characteristics; packing only); default, when "
           "absent: lagrangian for model.kernel = \"packing\", eulerian for the seed kernel (the only "
           "formulation it has)", choices=("eulerian", "lagrangian")),
    _Field("numerics", "points_per_diameter", "int", 10, "grid cells per sphere diameter (the "
           "interaction radius d must span at least 2 cells)", "", 2, 1000),
    _Field("numerics", "cfl", "float", None, "Courant number override (default: the preset's; the packing "
           "kernel's: 0.25 eulerian, 0.4 eulerian with range_over_d = 0, 0.5 lagrangian, 0.25 lagrangian with "
           "restitution 1); "
           "at most the chosen stepper's stability limit (packing: 0.5 eulerian, 0.9 lagrangian, 0.25 "
           "lagrangian with restitution 1); at least 0.001 (a smaller one only multiplies the steps)", "", 1e-3, 4),
    _Field("numerics", "stepper", "str", None, "Runge-Kutta stepper override (default: the "
           "preset's)", choices=_STEPPERS),
    _Field("numerics", "rtol", "float", None, "relative tolerance for adaptive time stepping "
           "(needs a stepper with an embedded pair: heun, kutta3, bs32; default: off)", "", 0, 1,
           lo_open=True, hi_open=True),
    _Field("numerics", "atol", "pair", None, "absolute tolerances [u in m/s, rho in kg/m] of adaptive "
           "stepping (default [1e-6, 1e-6]; only with rtol)", "", 0, 1e3, lo_open=True),
    _Field("numerics", "domain_height", "float", None, "height of the computational domain "
           "(default: the energy bound; at least the energy bound)", "m", 0, 1e4, lo_open=True),
)

_BY_NAME = {f.name: f for f in FIELDS}
_TABLES = ("model", "column", "tap", "run", "numerics")
_TABLE_DOC = {
    "model": "the interaction: the seed's kernel or the packing continuum",
    "column": "the spheres and the continuum constants",
    "tap": "half-sine displacement pulses of the floor (seed eq. 4.5)",
    "run": "times; output goes to the netCDF file given to `bsrflow run --out` (default: CONFIG with .nc)",
    "numerics": "grid and scheme",
}
_ALIASES = {
    "f": "tap.frequency", "tap_start": "tap.start", "tap_period": "tap.period",
    "ppd": "numerics.points_per_diameter", "d": "column.diameter", "e": "column.restitution",
    "eps": "column.kernel_dissipation", "N": "column.n_spheres", "K": "column.stiffness",
    "g": "column.gravity", "taps": "tap.n_taps",
}
# ColumnSetup's parameter names -> dotted fields (to rename its messages)
_SETUP_NAMES = {
    "n_spheres": "column.n_spheres", "diameter": "column.diameter", "density": "column.density",
    "stiffness": "column.stiffness", "restitution": "column.restitution", "m0": "column.m0",
    "kernel_dissipation": "column.kernel_dissipation", "gravity": "column.gravity",
    "a_over_d": "tap.a_over_d", "frequency": "tap.frequency", "tap_start": "tap.start",
    "n_taps": "tap.n_taps", "tap_period": "tap.period", "t_end": "run.t_end",
    "save_every": "run.save_every", "points_per_diameter": "numerics.points_per_diameter",
    "domain_height": "numerics.domain_height", "scheme": "numerics.scheme", "cfl": "numerics.cfl",
    "stepper": "numerics.stepper", "rtol": "numerics.rtol", "impulses": "tap.impulses",
    "period": "tap.period", "start": "tap.start", "amplitude": "tap.a_over_d",
    "kernel_name": "model.kernel", "formulation": "numerics.formulation",
    "stiffness_factor": "model.stiffness_factor", "range_over_d": "model.range_over_d",
}


def _short_names() -> dict[str, str]:
    leaf: dict[str, list[str]] = {}
    for f in FIELDS:
        leaf.setdefault(f.key, []).append(f.name)
    out = {k: v[0] for k, v in leaf.items() if len(v) == 1}
    out.update(_ALIASES)
    return out


_SHORT = _short_names()


def field_range(key: str, numeric: bool = False) -> str | None:
    """The valid range (with units) of the config field ``key`` (dotted, short, alias, a
    ColumnSetup name, or any table prefix before a short name: ``tap.f``), as the config's errors
    state it; None for a key that names no field (and, with ``numeric``, for one that is not a
    number)."""
    leaf = key.rpartition(".")[2]
    for name in (key, _SHORT.get(key), _SETUP_NAMES.get(key), _SHORT.get(leaf), _SETUP_NAMES.get(leaf)):
        f = _BY_NAME.get(name) if name else None
        if f is not None:
            return None if numeric and f.kind not in ("int", "float") else f.range_text()
    return None


def _suggest(word: str, candidates) -> str:
    m = difflib.get_close_matches(word, list(candidates), n=1, cutoff=0.6)
    return m[0] if m else ""


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_toml_value(a) for a in v) + "]"
    if v is None:
        return "(absent)"
    return repr(v)


def _describe(v) -> str:
    """How a TOML value of the wrong type is named in messages."""
    if isinstance(v, bool):
        return f"the boolean {_toml_value(v)}"
    if isinstance(v, int):
        return f"the integer {v}"
    if isinstance(v, float):
        return f"the float {v!r}"
    if isinstance(v, str):
        return f"the string {_toml_value(v)}"
    if isinstance(v, list):
        return "an array"
    if isinstance(v, dict):
        return "a table"
    return f"a {type(v).__name__} ({v})"


def _check_type(f: _Field, v):
    """Return v converted to the field's type, or raise ConfigError."""
    if f.kind == "int":
        if isinstance(v, int) and not isinstance(v, bool):
            return v
        hint = (f" (write {int(v)})" if isinstance(v, float) and math.isfinite(v) and v == int(v)
                and f.in_range(int(v)) else "")
        raise ConfigError(f.name, f"expected an integer, got {_describe(v)}{hint}; valid range "
                          f"{f.range_text()}", v, f.range_text())
    if f.kind == "float":
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            return float(v)
        raise ConfigError(f.name, f"expected a number{(' [' + f.unit + ']') if f.unit else ''}, got "
                          f"{_describe(v)}; valid range {f.range_text()}", v, f.range_text())
    if f.kind == "pair":
        if (isinstance(v, (list, tuple)) and len(v) == 2
                and all(isinstance(a, (int, float)) and not isinstance(a, bool) for a in v)):
            return (float(v[0]), float(v[1]))
        raise ConfigError(f.name, f"expected an array of two numbers [m/s, kg/m], got {_describe(v)}; "
                          f"valid range: each in {f.range_text()}", v, f.range_text())
    if f.kind == "bool":
        if isinstance(v, bool):
            return v
        raise ConfigError(f.name, f"expected true or false, got {_describe(v)}", v, "true or false")
    if f.kind == "str":
        if isinstance(v, str):
            if v in f.choices:
                return v
            near = _suggest(v, f.choices)
            raise ConfigError(f.name, f"{_toml_value(v)} is not valid; valid values: {f.range_text()}"
                              + (f' (did you mean "{near}"?)' if near else ""), v, f.range_text())
        raise ConfigError(f.name, f"expected a string, got {_describe(v)}; valid values: "
                          f"{f.range_text()}", v, f.range_text())
    raise AssertionError(f.kind)


def _range_error(f: _Field, v, hi=None, why: str = "") -> ConfigError:
    rng = f.range_text(hi)
    return ConfigError(f.name, f"{_toml_value(v)} is outside the valid range {rng}"
                       + (f" ({why})" if why else ""), v, rng)


_SEED_CONSTANTS = ("column.m0", "column.kernel_dissipation")   # refused with model.kernel = "packing"


# -- sections and the config ------------------------------------------------------------------
class Section(Mapping):
    """Read-only view of one table: ``cfg.tap.a_over_d`` or ``cfg.tap["a_over_d"]``."""

    def __init__(self, table: str, values: dict):
        object.__setattr__(self, "_table", table)
        object.__setattr__(self, "_values", values)

    def __getattr__(self, key):
        if key.startswith("_"):          # private or dunder lookups (e.g. by pickle before
            raise AttributeError(key)    # __init__ has run) must not recurse into _values
        try:
            return self._values[f"{self._table}.{key}"]
        except KeyError:
            raise AttributeError(f"[{self._table}] has no key {key!r}") from None

    def __setattr__(self, key, value):
        raise AttributeError("Config is read-only; use Config.with_overrides")

    def __getitem__(self, key):
        return self._values[f"{self._table}.{key}"]

    def __iter__(self):
        return (f.key for f in FIELDS if f.table == self._table)

    def __len__(self):
        return sum(1 for f in FIELDS if f.table == self._table)

    def __repr__(self):
        return f"[{self._table}] " + ", ".join(f"{k}={self[k]!r}" for k in self)


class Config:
    """A validated tapped-column configuration (immutable).

    Values are reached as ``cfg.column.diameter`` or ``cfg["column.diameter"]`` (SI units);
    optional keys that are absent are ``None``.  Build with :func:`load_config` or
    :meth:`from_dict`; change with :meth:`with_overrides`.
    """

    def __init__(self, values: dict, source: str | None = None, given=()):
        self._values = dict(values)
        self.source = source
        self._given = frozenset(given)      # the dotted names the user's tables set
        for t in _TABLES:
            setattr(self, t, Section(t, self._values))

    # construction -------------------------------------------------------------------------------
    @classmethod
    def default(cls) -> "Config":
        """The defaults (module docstring)."""
        return cls.from_dict({})

    @classmethod
    def from_dict(cls, d: Mapping, source: str | None = None) -> "Config":
        """Validate a nested mapping ``{"column": {...}, "tap": {...}, ...}`` (as ``tomllib``
        returns it) and fill defaults.  Raises :class:`ConfigError`."""
        if not isinstance(d, Mapping):
            raise ConfigError("config", f"expected a table, got {_describe(d)}")
        values = {f.name: f.default for f in FIELDS}
        given: set[str] = set()
        for table, body in d.items():
            if table not in _TABLES:
                if table in _SHORT and not isinstance(body, Mapping):   # a key outside any table
                    raise ConfigError(table, f"a key outside any table; put it in "
                                      f"[{_SHORT[table].split('.')[0]}] (as {_SHORT[table]})", body)
                near = _suggest(table, _TABLES)
                layer = ("; a 2-D/3-D or bed config needs a [layer] table (its [output] and [tracers] go with it)"
                         if table in ("output", "tracers") else "")
                raise ConfigError(table, "unknown table" + (f"; did you mean [{near}]?" if near else "")
                                  + f" (valid tables: {', '.join(_TABLES)}){layer}", body)
            if not isinstance(body, Mapping):
                raise ConfigError(table, f"expected a table [{table}], got {_describe(body)}", body)
            for key, v in body.items():
                name = f"{table}.{key}"
                f = _BY_NAME.get(name)
                if f is None:
                    keys = [g.key for g in FIELDS if g.table == table]
                    near = _suggest(key, keys)
                    if near:
                        hint = f"; did you mean {table}.{near}?"
                    elif key in _SHORT:
                        hint = f"; it belongs in another table: {_SHORT[key]}"
                    else:
                        other = _suggest(key, _SHORT)
                        hint = f"; did you mean {_SHORT[other]}?" if other else ""
                    raise ConfigError(name, f"unknown key in [{table}]{hint} (valid keys: "
                                      f"{', '.join(keys)})", v)
                values[name] = _check_type(f, v)
                given.add(name)
        cfg = cls(values, source, given)
        cfg._validate()
        return cfg

    def with_overrides(self, overrides: Mapping[str, Any]) -> "Config":
        """A new validated config with some values replaced.  Keys: dotted names
        (``"tap.a_over_d"``), unique short names (``"a_over_d"``, ``"t_end"``) or the aliases
        ``f`` (tap.frequency), ``d`` (column.diameter), ``e`` (column.restitution), ``eps``
        (column.kernel_dissipation), ``N`` (column.n_spheres), ``K`` (column.stiffness), ``g``
        (column.gravity), ``taps`` (tap.n_taps), ``ppd`` (numerics.points_per_diameter), and
        ColumnSetup's ``tap_start``, ``tap_period``.  A value ``None`` removes an optional key, or
        the seed kernel's constants ``m0`` / ``kernel_dissipation`` (back to their defaults, no
        longer set: so a seed config becomes a packing one with ``{"kernel": "packing", "m0": None,
        "eps": None}``)."""
        nested = self._given_dict()
        for key, v in overrides.items():
            name = self.resolve_key(key)
            table, k = name.split(".")
            if v is None:
                if _BY_NAME[name].default is not None and name not in _SEED_CONSTANTS:
                    raise ConfigError(name, "cannot be removed (it is not optional)")
                nested.get(table, {}).pop(k, None)
            else:
                nested.setdefault(table, {})[k] = v
        return Config.from_dict(nested, self.source)

    @staticmethod
    def resolve_key(key: str) -> str:
        """The dotted field name of ``key`` (dotted, short or alias); ConfigError if unknown."""
        if key in _BY_NAME:
            return key
        if key in _SHORT:
            return _SHORT[key]
        near = _suggest(key, list(_BY_NAME) + list(_SHORT))
        near = _SHORT.get(near, near)
        raise ConfigError(key, "unknown key" + (f"; did you mean {near}?" if near else "")
                          + f" (valid keys: {', '.join(_BY_NAME)})")

    # validation ---------------------------------------------------------------------------------
    def _validate(self):
        v = self._values
        for f in FIELDS:
            x = v[f.name]
            if x is None or f.kind in ("bool", "str") or f.name in ("run.save_every", "run.checkpoint_every"):
                continue                        # (the last two: below, with t_end)
            if f.kind == "pair":
                if not all(f.in_range(a) for a in x):
                    raise ConfigError(f.name, f"{_toml_value(x)} is outside the valid range: each in "
                                      f"{f.range_text()}", x, f.range_text())
                continue
            if not f.in_range(x):
                why = ""
                if f.name == "numerics.points_per_diameter" and x < 2:
                    why = "the interaction radius d must span at least 2 cells"
                raise _range_error(f, x, why=why)
        t_end = v["run.t_end"]
        f = _BY_NAME["run.save_every"]
        if not (math.isfinite(v["run.save_every"]) and 0.0 < v["run.save_every"] <= t_end):
            raise _range_error(f, v["run.save_every"], t_end, f"at most run.t_end = {t_end:g} s")
        if t_end / v["run.save_every"] > _MAX_SNAPSHOTS:
            raise ConfigError(f.name, f"{v['run.save_every']!r} gives {t_end / v['run.save_every']:.3g} "
                              f"snapshots; valid range [{t_end / _MAX_SNAPSHOTS:.3g}, {t_end:g}] s "
                              f"(at most {_MAX_SNAPSHOTS} snapshots)", v["run.save_every"])
        f = _BY_NAME["run.checkpoint_every"]
        ce = v["run.checkpoint_every"]
        if ce is not None and ce != 0.0 and not (math.isfinite(ce) and t_end / _MAX_CHECKPOINTS <= ce <= t_end):
            rng = f"0 (off) or [{t_end / _MAX_CHECKPOINTS:.3g}, {t_end:g}] s"
            raise ConfigError(f.name, f"{ce!r} is outside the valid range {rng} (at most run.t_end, "
                              f"at most {_MAX_CHECKPOINTS} checkpoints)", ce, rng)
        if v["tap.n_taps"] > 1 and v["tap.period"] < 0.5 / v["tap.frequency"]:
            dur = 0.5 / v["tap.frequency"]
            rng = f"[{dur:g}, 1e+05] s"
            raise ConfigError("tap.period", f"{v['tap.period']!r} is outside the valid range {rng}: "
                              f"shorter than one tap, which lasts 1/(2f) = {dur:g} s", v["tap.period"], rng)
        if v["model.kernel"] == "packing":
            for key in _SEED_CONSTANTS:
                if key in self._given:
                    raise ConfigError(key, f"{v[key]!r}: a constant of the seed kernel, which does not enter "
                                      'the packing continuum (only K, e, d, density, N and g do); with '
                                      'model.kernel = "packing" remove it (`bsrflow init --kernel packing` '
                                      "writes a packing config)", v[key])
            if v["model.stiffness_mach"] > 0.0 and (v["model.stiffness_factor"] != 1.0
                                                    or "model.stiffness_factor" in self._given):
                raise ConfigError("model.stiffness_mach", f"{v['model.stiffness_mach']!r} together with "
                                  f"model.stiffness_factor = {v['model.stiffness_factor']!r}: give one of the two",
                                  v["model.stiffness_mach"])
            for key in ("numerics.stepper", "numerics.rtol", "numerics.atol"):
                if v[key] is not None:
                    raise ConfigError(key, f"{_toml_value(v[key])}: an option of the seed kernel's solver; "
                                      'with model.kernel = "packing" remove it', v[key])
            if v["numerics.scheme"] != "seed":
                raise ConfigError("numerics.scheme", f'"{v["numerics.scheme"]}": a preset of the seed kernel\'s '
                                  'solver; with model.kernel = "packing" remove it (the packing formulations '
                                  "have their own schemes)", v["numerics.scheme"])
            self.column_setup(domain_height=None)
            return self._validate_domain()
        if v["numerics.formulation"] not in (None, "eulerian"):
            raise ConfigError("numerics.formulation", f'"{v["numerics.formulation"]}" is an option of '
                              'model.kernel = "packing"; the seed kernel is solved on the grid (valid: "eulerian")',
                              v["numerics.formulation"])
        if v["model.range_over_d"] is not None:
            raise ConfigError("model.range_over_d", f"{v['model.range_over_d']!r}: an option of "
                              'model.kernel = "packing" (the seed kernel\'s range is d)', v["model.range_over_d"])
        if v["run.write_state"]:
            raise ConfigError("run.write_state", 'true: an option of model.kernel = "packing" (the seed '
                              "kernel's state, u and rho on the grid, is written in every file)", True)
        if v["model.stiffness_mach"] != 0.0:
            raise ConfigError("model.stiffness_mach", f"{v['model.stiffness_mach']!r}: an option of "
                              'model.kernel = "packing"', v["model.stiffness_mach"])
        if v["model.stiffness_factor"] != 1.0:
            raise ConfigError("model.stiffness_factor", f"{v['model.stiffness_factor']!r}: an option of "
                              'model.kernel = "packing" (the seed kernel\'s stiffness is set by column.m0)',
                              v["model.stiffness_factor"])
        # scheme: stepper, stability limit, adaptive stepping
        preset = _preset(v["numerics.scheme"])
        stepper = v["numerics.stepper"] or preset.stepper
        filt = preset.filter
        limit = _cfl_limit(stepper, filt)
        if limit == 0.0:
            raise ConfigError("numerics.stepper", f'"{stepper}" without the moving average (scheme '
                              f'"{v["numerics.scheme"]}") is unstable at every CFL number; valid '
                              'values: "kutta3", "rk4", "bs32", "rk4_0.4_0.25", or scheme = "seed"', stepper)
        cfl = v["numerics.cfl"] if v["numerics.cfl"] is not None else preset.cfl
        if cfl > limit:
            f = _BY_NAME["numerics.cfl"]
            rng = f"[0.001, {limit:g}]"
            where = "numerics.cfl" if v["numerics.cfl"] is not None else "numerics.stepper"
            raise ConfigError(where, f"CFL {cfl!r} is above the stability limit {limit:g} of "
                              f"{stepper}{' + moving average' if filt else ''}; valid range {rng}",
                              cfl, rng)
        if v["numerics.rtol"] is not None and stepper not in _EMBEDDED:
            raise ConfigError("numerics.rtol", f"{v['numerics.rtol']!r}: adaptive stepping needs a stepper "
                              f'with an embedded pair (heun, kutta3, bs32), but the stepper is "{stepper}"; '
                              'set numerics.stepper = "bs32" or remove rtol', v["numerics.rtol"])
        if v["numerics.atol"] is not None and v["numerics.rtol"] is None:
            raise ConfigError("numerics.atol", f"{_toml_value(v['numerics.atol'])} given without numerics.rtol; "
                              "absolute tolerances apply only to adaptive stepping (set rtol, or remove atol)",
                              v["numerics.atol"])
        self._validate_domain()
        self.scheme()

    def _validate_domain(self):
        """The domain height and the number of cells."""
        v = self._values
        # the column (ColumnSetup validates again; its messages are renamed to dotted fields)
        setup = self.column_setup(domain_height=None)
        if v["model.kernel"] == "seed":
            self._check_seed_settled_height(setup)
        if v["numerics.domain_height"] is not None:
            need = setup.energy_bound_height()
            if v["numerics.domain_height"] < need:
                rng = f"[{need:.6g}, 1e+04] m"
                raise ConfigError("numerics.domain_height", f"{v['numerics.domain_height']!r} is outside "
                                  f"the valid range {rng}: the energy bound predicts flight up to "
                                  f"{need:.4g} m", v["numerics.domain_height"], rng)
        H = v["numerics.domain_height"] or setup.energy_bound_height()
        if v["numerics.domain_height"] is None and H > _MAX_HEIGHT:
            raise self._height_error(setup, H)
        n_cells = H / v["column.diameter"] * v["numerics.points_per_diameter"]
        if n_cells > _MAX_CELLS:
            ppd = v["numerics.points_per_diameter"]
            best = int(_MAX_CELLS * v["column.diameter"] / H)
            if best >= 2:
                raise ConfigError("numerics.points_per_diameter", f"{ppd} gives {n_cells:.3g} cells over "
                                  f"the domain height {H:.4g} m (at most {_MAX_CELLS}); valid range here: "
                                  f"integers in [2, {best}]", ppd, f"[2, {best}]")
            raise ConfigError("column.diameter", f"{v['column.diameter']!r} m is too small for the domain "
                              f"height {H:.4g} m: even 2 cells per diameter give {2 * H / v['column.diameter']:.3g} "
                              f"cells (at most {_MAX_CELLS})", v["column.diameter"])

    def taps_not_reached(self) -> str | None:
        """A one-line note when some of the taps the config sets (tap.start, tap.n_taps or
        tap.period given) start at or after ``run.t_end`` (the run ends before them), else None.
        Not an error (``bsrflow init`` writes every field, so a settling run made from such a file
        has them), and nothing for the default tap at 0.4 s that a short run of the defaults
        never reaches."""
        v = self._values
        n, start, period, t_end = v["tap.n_taps"], v["tap.start"], v["tap.period"], v["run.t_end"]
        if n < 1 or not {"tap.start", "tap.n_taps", "tap.period"} & self._given:
            return None
        reached = 0 if start >= t_end else min(n, max(1, math.ceil((t_end - start) / period)))
        if reached == n:
            return None
        return (f"note: {n - reached} of the {n} tap(s) start at or after run.t_end = {t_end:g} s (tap.start = "
                f"{start:g} s, tap.period = {period:g} s); the run ends before them")

    def _check_seed_settled_height(self, setup):
        """The seed kernel's continuum is a γ = 2 gas: at rest under gravity it settles to the height
        H_s = sqrt(2 N d c0²/g) (c0 = sqrt(K d²/(3 m0)), its sound speed at the stacked density;
        density linear in height).  Below one diameter the column of N spheres would be squeezed
        into less than one sphere; the run then ends in a gradient catastrophe (K = 1e3 N/m at the
        defaults: H_s = 0.27 d, stopped at t = 0.41 s; 3e3 N/m, H_s = 0.47 d, still ran).  Refused,
        naming column.m0 when it was set and the stiffness was not, else column.stiffness."""
        v = self._values
        n, d, g = v["column.n_spheres"], v["column.diameter"], v["column.gravity"]
        c0 = setup.sound_speed()
        h_s = math.sqrt(2.0 * n * d * c0 * c0 / g)
        if h_s >= d:
            return
        problem = (f"the seed kernel's continuum would settle under its weight to "
                   f"sqrt(2 N d c0^2/g) = {h_s / d:.3g} d (c0 = sqrt(K d^2/(3 m0)) = {c0:.3g} m/s; at least 1 d)")
        k_min = 3.0 * v["column.m0"] * g / (2.0 * n * d)
        m0_max = 2.0 * n * d * v["column.stiffness"] / (3.0 * g)
        if "column.m0" in self._given and "column.stiffness" not in self._given and m0_max >= 1e-12:
            rng = f"[1e-12, {m0_max:.4g}] kg"
            raise ConfigError("column.m0", f"{v['column.m0']!r} is outside the valid range {rng} here: {problem}",
                              v["column.m0"], rng)
        rng = f"[{max(k_min, 1e-3):.4g}, 1e+12] N/m"
        raise ConfigError("column.stiffness", f"{v['column.stiffness']!r} is outside the valid range {rng} here: "
                          f"{problem}", v["column.stiffness"], rng)

    def _height_error(self, setup, H) -> ConfigError:
        """The energy-bound domain is taller than _MAX_HEIGHT: name the dominating cause."""
        v = self._values
        g, d = v["column.gravity"], v["column.diameter"]
        launch = 3.0 * setup.amplitude * setup.omega if v["tap.n_taps"] > 0 else 0.0
        c0 = setup.sound_speed()
        vmax = math.sqrt(max(0.0, 2.0 * g * (_MAX_HEIGHT - (v["column.n_spheres"] + 3) * d)))
        if 2.0 * c0 >= launch and vmax > launch:
            c_ok = (vmax - launch) / 2.0
            m0_min = v["column.stiffness"] * d * d / (3.0 * c_ok * c_ok)
            rng = f"[{m0_min:.4g}, 1e+12] kg"
            return ConfigError("column.m0", f"{v['column.m0']!r} is outside the valid range {rng} here: "
                               f"the kernel's sound speed c0 = sqrt(K d^2/(3 m0)) = {c0:.4g} m/s makes the "
                               f"energy-bound domain {H:.4g} m tall (at most {_MAX_HEIGHT:g} m)",
                               v["column.m0"], rng)
        # the launch alone exceeds the domain's energy bound: no m0 helps, the tap must be smaller
        a_max = (vmax if vmax <= launch else max(vmax - 2.0 * c0, 0.0)) / (3.0 * setup.omega) / d
        rng = f"[0, {a_max:.4g}]"
        return ConfigError("tap.a_over_d", f"{v['tap.a_over_d']!r} is outside the valid range {rng} here: "
                           f"the launch speed 3 a w = {launch:.4g} m/s makes the energy-bound domain "
                           f"{H:.4g} m tall (at most {_MAX_HEIGHT:g} m)", v["tap.a_over_d"], rng)

    # derived objects ----------------------------------------------------------------------------
    @property
    def formulation(self) -> str:
        """``numerics.formulation``, or when absent the kernel's default: "lagrangian" for the
        packing kernel, "eulerian" for the seed kernel."""
        f = self._values["numerics.formulation"]
        if f is not None:
            return f
        return "lagrangian" if self._values["model.kernel"] == "packing" else "eulerian"

    def column_setup(self, **kw):
        """:class:`bsrflow.physics.column.ColumnSetup` with these values (keywords override)."""
        from ..physics.column import ColumnSetup
        v = self._values
        args = dict(
            n_spheres=v["column.n_spheres"], diameter=v["column.diameter"], density=v["column.density"],
            stiffness=v["column.stiffness"], restitution=v["column.restitution"], m0=v["column.m0"],
            kernel_dissipation=v["column.kernel_dissipation"], gravity=v["column.gravity"],
            a_over_d=v["tap.a_over_d"], frequency=v["tap.frequency"], tap_start=v["tap.start"],
            n_taps=v["tap.n_taps"], tap_period=v["tap.period"], t_end=v["run.t_end"],
            points_per_diameter=v["numerics.points_per_diameter"], scheme=v["numerics.scheme"],
            save_every=v["run.save_every"], domain_height=v["numerics.domain_height"],
            impulses=v["tap.impulses"], kernel_name=v["model.kernel"], formulation=self.formulation,
            stiffness_factor=v["model.stiffness_factor"])
        if v["model.kernel"] == "packing":
            args["cfl"] = v["numerics.cfl"]
            args["range_over_d"] = v["model.range_over_d"]
        args.update(kw)
        try:
            setup = ColumnSetup(**args)
            if v["model.kernel"] == "packing" and v["model.stiffness_mach"] > 0.0 and "stiffness_factor" not in kw:
                from ..physics.column import suggest_stiffness_factor
                setup = setup.with_(stiffness_factor=suggest_stiffness_factor(setup, v["model.stiffness_mach"]))
            return setup
        except ValueError as exc:
            raise _renamed(exc) from None

    def scheme(self):
        """:class:`bsrflow.numerics.solver.Scheme`: the preset with the cfl/stepper/rtol overrides."""
        from ..numerics.solver import Scheme
        over = {}
        for k in ("cfl", "stepper", "rtol", "atol"):
            if self._values[f"numerics.{k}"] is not None:
                over[k] = self._values[f"numerics.{k}"]
        try:
            return Scheme.preset(self._values["numerics.scheme"], **over)
        except ValueError as exc:
            raise _renamed(exc) from None

    def save_times(self):
        """Snapshot times [s] from 0 to t_end (``solver.save_schedule``)."""
        from ..numerics.solver import save_schedule
        return save_schedule(0.0, self._values["run.t_end"], self._values["run.save_every"])

    def checkpoint_interval(self) -> float:
        """The checkpoint interval [s]: run.checkpoint_every, or when absent the default
        0.1 s rounded up to a whole number of snapshots (and at least t_end/1000); 0: off."""
        ce = self._values["run.checkpoint_every"]
        if ce is not None:
            return float(ce)
        se, t_end = self._values["run.save_every"], self._values["run.t_end"]
        k = max(1, math.ceil(max(_AUTO_CHECKPOINT, t_end / _AUTO_CHECKPOINTS) / se - 1e-9))
        return k * se

    def checkpoint_times(self):
        """Checkpoint times [s]: every run.checkpoint_every from 0, strictly inside (0, t_end).

        A checkpoint time within round-off (1e-9 save_every) of a snapshot time is that snapshot
        time exactly (the same float of :meth:`save_times`): checkpoints every whole number of
        snapshots then add no event to the run, so its step sequence and results are bit for
        bit those of the run without checkpoints."""
        import numpy as np
        ce, t_end = self.checkpoint_interval(), self._values["run.t_end"]
        if ce <= 0.0:
            return np.zeros(0)
        n = int(np.floor(t_end / ce + 1e-9))
        ts = ce * np.arange(1, n + 1)
        saves = self.save_times()
        se = self._values["run.save_every"]
        j = np.clip(np.rint(ts / se).astype(np.int64), 0, saves.size - 1)
        near = np.abs(saves[j] - ts) <= 1e-9 * se
        ts = np.where(near, saves[j], ts)
        return ts[ts < t_end - 1e-12 * max(1.0, t_end)]

    # access and output --------------------------------------------------------------------------
    def __getitem__(self, name: str):
        return self._values[self.resolve_key(name)]

    def __eq__(self, other):
        return isinstance(other, Config) and self._values == other._values

    def __repr__(self):
        return "Config(" + ", ".join(f"{k}={v!r}" for k, v in self._values.items() if v is not None) + ")"

    def _given_dict(self) -> dict:
        """Like :meth:`to_dict`, only the fields the user's tables set (the others keep their
        defaults when the dict is read back)."""
        out: dict = {t: {} for t in _TABLES}
        for f in FIELDS:
            val = self._values[f.name]
            if f.name in self._given and val is not None:
                out[f.table][f.key] = list(val) if isinstance(val, tuple) else val
        return out

    def to_dict(self) -> dict:
        """Nested plain dict ``{table: {key: value}}``; absent optional keys are left out."""
        out: dict = {t: {} for t in _TABLES}
        for f in FIELDS:
            val = self._values[f.name]
            if val is not None:
                out[f.table][f.key] = list(val) if isinstance(val, tuple) else val
        return out

    def to_toml(self) -> str:
        """Commented TOML text (units, valid ranges) that :func:`load_config` reads back to an
        equal config.  Absent optional keys appear commented out."""
        lines = [
            "# bsrflow: the vertically tapped column of spheres (BSR continuum model).",
            "# Run with `bsrflow run THIS_FILE [--out FILE.nc]`.  SI units throughout.  Every key is",
            "# optional (the package default is used when absent); valid ranges: [a, b] closed,",
            "# (a, b) open.  `bsrflow run` checks every value before it starts.",
        ]
        for t in _TABLES:
            lines += ["", f"[{t}]  # {_TABLE_DOC[t]}"]
            for f in FIELDS:
                if f.table != t:
                    continue
                unit = f" [{f.unit}]" if f.unit else ""
                rng = f.range_text()
                if f.name == "run.save_every":
                    rng = "(0, t_end] s"
                elif f.name == "run.checkpoint_every":
                    rng = "0 (off) or (0, t_end] s"
                elif f.name == "numerics.cfl":
                    rng = ("[0.001, limit]: euler 0.7071, heun 1.5289, kutta3/bs32 2.3388, rk4 3.1010 with "
                           "the moving average (seed); kutta3/bs32 1.7321, rk4/rk4_0.4_0.25 2.8284 without (accurate)")
                lines.append(f"# {f.doc}{unit}; valid: {rng}")
                val = self._values[f.name]
                if f.name in _SEED_CONSTANTS and self._values["model.kernel"] == "packing":
                    lines.append(f"# {f.key} = {_toml_value(val)}  # the seed kernel's only: refused with "
                                 'model.kernel = "packing"')
                elif val is None:
                    example = {"run.checkpoint_every": "0.1", "numerics.cfl": "0.5", "numerics.stepper": '"bs32"', "numerics.rtol": "1e-4",
                               "model.range_over_d": '1.0  # with model.kernel = "packing"',
                               "numerics.formulation": '"lagrangian"  # with model.kernel = "packing"',
                               "numerics.atol": "[1e-3, 1e-3]", "numerics.domain_height": "3.5"}[f.name]
                    lines.append(f"# {f.key} = {example}")
                else:
                    lines.append(f"{f.key} = {_toml_value(val)}")
        return "\n".join(lines) + "\n"


def _preset(name):
    from ..numerics.solver import Scheme
    return Scheme.preset(name)


_NAME_RE = re.compile(r"^(\w+) = (.*)$", re.S)


def _renamed(exc: ValueError) -> ConfigError:
    """A ColumnSetup/Scheme ValueError 'name = value ...' as a ConfigError naming the dotted field."""
    msg = str(exc)
    m = _NAME_RE.match(msg)
    if m and m.group(1) in _SETUP_NAMES:
        return ConfigError(_SETUP_NAMES[m.group(1)], m.group(2))
    return ConfigError("config", msg)


# -- files ----------------------------------------------------------------------------------------
_TOML_POS = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")


def load_config(path) -> Config:
    """Read and validate a TOML config file.  Raises :class:`ConfigError` (one line) for a missing
    or unreadable file, a TOML syntax error (with the line number), a file without tables (empty or
    only comments) or an invalid value."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(path, f"no such config file (write one with `bsrflow init {path}`)") from None
    except IsADirectoryError:
        raise ConfigError(path, "is a directory, not a config file") from None
    except PermissionError:
        raise ConfigError(path, "cannot read the config file (permission denied)") from None
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = _TOML_POS.search(msg)
        if m:
            msg = f"line {m.group(1)}, column {m.group(2)}: invalid TOML: {msg[:m.start()]}"
        else:
            msg = f"invalid TOML: {msg}"
        raise ConfigError(path, msg) from None
    except UnicodeDecodeError as exc:
        raise ConfigError(path, f"invalid TOML: the file is not UTF-8 text ({exc.reason} at byte "
                          f"{exc.start})") from None
    if not data:          # a mistyped or unsaved file ran the default column silently
        raise ConfigError(path, "the config has no tables (it is empty or only comments); `bsrflow init "
                          "NEW.toml` writes one with every field and its default")
    return Config.from_dict(data, source=path)


def saved_config(text: str) -> Config:
    """The config of a TOML text written by :meth:`Config.to_toml` into an output or checkpoint.
    Files written before the seed kernel's constants were refused with the packing kernel carry
    ``column.m0`` and ``column.kernel_dissipation`` there; they are dropped for such a config."""
    data = tomllib.loads(text)
    if isinstance(data.get("model"), dict) and data["model"].get("kernel") == "packing":
        for key in _SEED_CONSTANTS:
            data.get("column", {}).pop(key.split(".")[1], None)
    return Config.from_dict(data)


def default_config_text(kernel: str = "seed") -> str:
    """The commented default config (what ``bsrflow init`` writes): the seed's kernel, or with
    ``kernel="packing"`` the packing continuum (its Lagrangian formulation, the default)."""
    if kernel == "seed":
        return Config.default().to_toml()
    return Config.from_dict({"model": {"kernel": kernel}}).to_toml()


def parse_override(text: str) -> tuple[str, Any]:
    """``"KEY=VALUE"`` (as given to ``bsrflow run --set``) -> (dotted key, value).  VALUE is read as
    a TOML value (``0.5``, ``3``, ``true``, ``"accurate"``); a bare word is taken as a string."""
    if "=" not in text:
        raise ConfigError(text, "expected KEY=VALUE (e.g. tap.a_over_d=0.5)")
    key, _, raw = text.partition("=")
    key = Config.resolve_key(key.strip())
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value
