"""Physical units: parsing quantities and converting the dimensionless results (pint).

The dimensionless results stay the core (:mod:`roughflow.datasets.units` names the
reference units ``ref_length`` = L, ``ref_pressure`` = E*, ``ref_viscosity`` = eta). This
thin layer parses user quantities ("200GPa", "1mPa.s", "1MPa:100MPa:20"), converts with
:class:`Scales`, and builds pint registries in which the reference units are defined from
a dataset's attributes. pint is imported on first use (about 1 s), so commands that need
no units do not pay for it.

Example (plain pint, no pint-xarray needed)::

    ds = xr.open_dataset("leak.nc")
    ureg = roughflow.units.registry(ds.attrs)
    gap_m = ureg.Quantity(ds["mean_gap"].values, ds["mean_gap"].attrs["units"]).to("m")
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from roughflow.errors import InputError

if TYPE_CHECKING:
    import pint
    from numpy.typing import ArrayLike

__all__ = ["REF_LENGTH", "REF_PRESSURE", "REF_VISCOSITY", "REFERENCE_ATTRS", "REFERENCE_VARIABLES",
           "DIMENSIONS", "registry", "SI_DIGITS", "canonical", "parse_quantity", "parse_range",
           "RATE_UNITS", "parse_rate_unit", "Scales", "leak_rate"]

#: The reference units of the dimensionless system (roughflow.datasets.units describes them;
#: they live here, below the datasets, because scan import and the leak question use them).
REF_LENGTH = "ref_length"
REF_PRESSURE = "ref_pressure"
REF_VISCOSITY = "ref_viscosity"
#: Dataset attribute holding the SI value of each reference unit, and that SI unit.
REFERENCE_ATTRS = {
    REF_LENGTH: ("ref_length_m", "m"),
    REF_PRESSURE: ("ref_pressure_Pa", "Pa"),
    REF_VISCOSITY: ("ref_viscosity_Pa_s", "Pa*s"),
}

#: Variable over ``scan`` of a leak dataset holding the SI value of each reference unit:
#: the scans of a measured study may differ in it (then no attribute holds it).
REFERENCE_VARIABLES = {
    REF_LENGTH: "length_scale",
    REF_PRESSURE: "modulus",
    REF_VISCOSITY: "viscosity",
}

#: What each kind of quantity must convert to (pint dimensionality, SI unit).
DIMENSIONS = {
    "length": ("[length]", "m"),
    "pressure": ("[pressure]", "Pa"),
    "viscosity": ("[pressure] * [time]", "Pa*s"),
    "volume rate": ("[length] ** 3 / [time]", "m^3/s"),
}


@functools.lru_cache(maxsize=1)
def _base_registry():
    import pint

    return pint.UnitRegistry()


@functools.lru_cache(maxsize=16)
def _registry(scales: tuple[tuple[str, float | None], ...]):
    import pint

    ureg = pint.UnitRegistry()
    for name, value in scales:
        si = REFERENCE_ATTRS[name][1]
        # an unknown scale: the reference unit is a base dimension of its own
        ureg.define(f"{name} = [{name}]" if value is None else f"{name} = {value!r} * {si}")
    return ureg


def registry(source: Mapping | None = None) -> pint.UnitRegistry:
    """A pint UnitRegistry that parses every ``units`` string roughflow writes.

    ``source`` is a dataset's attributes, or the dataset itself. The reference units are
    defined from the attributes of :data:`roughflow.datasets.units.REFERENCE_ATTRS` where
    they hold a positive finite SI value; given a dataset, an attribute it lacks is taken
    from the matching per-scan variable
    (:data:`~roughflow.datasets.units.REFERENCE_VARIABLES`) where that holds one value, as
    after ``ds.sel(scan=name)`` on a measured study whose scans differ in it. A reference
    unit found nowhere is a base dimension of its own (the strings parse, but do not
    convert to SI). Registries are cached.

    Raises :class:`InputError` for a dataset whose scans differ in a reference unit: no
    one registry converts all of them.
    """
    attrs = {} if source is None else getattr(source, "attrs", source)
    variables = getattr(source, "variables", {})
    scales = []
    for name, (key, _) in REFERENCE_ATTRS.items():
        value = attrs.get(key)
        var = REFERENCE_VARIABLES[name]
        if value is None and var in variables:
            values = np.unique(np.asarray(variables[var].values, dtype=float).ravel())
            if values.size > 1:
                raise InputError(
                    f"the scans of this dataset differ in {var} ({values.size} values, "
                    f"{values.min():g} - {values.max():g}), which defines {name}; take one "
                    "scan's registry: registry(ds.sel(scan=name))")
            value = values[0] if values.size else None
        try:
            v = float(value)
        except (TypeError, ValueError):
            v = math.nan
        scales.append((name, v if math.isfinite(v) and v > 0 else None))
    return _registry(tuple(scales))


#: Significant digits kept of a quantity converted to SI: one length or pressure written in
#: other units ("0.125um", "125nm"; "4.1GPa", "4100MPa") converts to floats an ulp apart,
#: which split a study's aggregation (a length scale that "differs", a pressure axis with
#: two 4.1 GPa). Twelve digits are far beyond any measured quantity.
SI_DIGITS = 12


def canonical(value: float) -> float:
    """``value`` rounded to :data:`SI_DIGITS` significant digits."""
    return float(f"{value:.{SI_DIGITS}g}")


#: A dot between unit names ("mPa.s", "N.s/m^2", "kg.m"), the product in SI notation, as
#: opposed to a decimal point (a digit on either side). pint < 0.26 skipped the unknown
#: operator, reading the implicit product; pint 0.26 (Python >= 3.12) raises on it.
_UNIT_DOT = re.compile(r"(?<=[^\W\d]|[)])\s*\.\s*(?=[^\W\d]|[(])")


#: A power written after a unit name without an operator ("m2", "s-1": "N.s/m2", "kg.m-3"),
#: SI notation that pint reads as an unknown unit name; not the exponent of a number ("1e-3",
#: "2E6"). Parenthesised, so that a dot after it reads as a product too ("m2.s").
_UNIT_POWER = re.compile(r"(?P<before>[\d.]?)(?P<unit>[^\W\d_]+)(?P<power>[+-]?\d+)")


def _unit_power(match: re.Match) -> str:
    if match["before"] and match["unit"] in ("e", "E"):
        return match[0]  # a number's exponent
    return f"{match['before']}({match['unit']}**{match['power']})"


def parse_quantity(text: str | float, kind: str, name: str) -> float:
    """SI value of ``text`` ("200GPa", "1 mPa s", "2mm", or a number already in SI units),
    which must be a positive quantity of ``kind`` (:data:`DIMENSIONS`), to
    :data:`SI_DIGITS` digits; ``name`` is the option or key reported in the error."""
    dim, si = DIMENSIONS[kind]
    if isinstance(text, (int, float, np.integer, np.floating)) and not isinstance(text, bool):
        value = float(text)
    else:
        import pint

        ureg = _base_registry()
        s = str(text).strip()
        try:
            q = ureg.Quantity(_UNIT_DOT.sub("*", _UNIT_POWER.sub(_unit_power, s)))
        except (pint.errors.PintError, ValueError, TypeError, AttributeError,
                SyntaxError) as exc:
            raise InputError(f"{name}: cannot parse {text!r} as a {kind} ({exc})") from None
        if isinstance(q, (int, float)) or q.dimensionless:
            raise InputError(f"{name}: {text!r} has no unit; give a {kind} such as "
                             f"'{_example(kind, name)}'")
        if q.dimensionality != ureg.get_dimensionality(dim):
            raise InputError(f"{name}: {text!r} is not a {kind} (its dimension is "
                             f"{q.dimensionality}, expected {dim})")
        value = float(q.to(si).magnitude)
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive {kind}, got {text!r}")
    return canonical(value)


_EXAMPLES = {"length": "2mm", "pressure": "1MPa", "viscosity": "1mPa.s",
             "volume rate": "1mL/min"}
#: Examples for quantities whose usual size is far from their kind's example: for a
#: modulus, "1MPa" suggested a value 2e5 times below a steel pair's E*.
_NAMED_EXAMPLES = {"modulus": "200GPa"}


def _example(kind: str, name: str) -> str:
    """An example value of the quantity ``name`` (an option, "--modulus", or a key,
    "modulus") of ``kind``, for messages."""
    return _NAMED_EXAMPLES.get(name.strip().lstrip("-").replace("-", "_"), _EXAMPLES[kind])


#: The powers of a unit expression ("m^3", "m**3", "mm3", "s-1"): the only digits a unit
#: without a number holds.
_POWERS = re.compile(r"(?:\^|\*\*)\s*[-+]?\d+|(?<=[^\W\d_])[-+]?\d+")

#: Common units of a leak rate, named where a rate unit is refused (``roughflow leak
#: --rate-unit``); any other volume per time that :func:`parse_quantity` reads is taken too.
RATE_UNITS = ("m^3/s", "mm^3/s", "cm^3/min", "L/min", "L/h", "mL/min", "mL/h", "uL/min",
              "uL/h")


def parse_rate_unit(text: str, name: str = "rate_unit") -> float:
    """SI value (m^3/s) of one ``text``, a unit of volume per time without a number
    ("mL/min": 1.667e-8), parsed as :func:`parse_quantity` parses; :class:`InputError`
    naming ``name``, the value and :data:`RATE_UNITS` for anything else."""
    s = str(text).strip()
    accepted = f"give a unit of volume per time such as {', '.join(RATE_UNITS)}"
    if not s or re.search(r"\d", _POWERS.sub("", s)):  # a number would scale every rate
        raise InputError(f"{name}: {text!r} is not a unit alone (the rates are converted to "
                         f"it, a number would scale them); {accepted}")
    try:
        return parse_quantity(s, "volume rate", name)
    except InputError as exc:
        raise InputError(f"{exc}; {accepted}") from None


def parse_range(text: str, kind: str, name: str) -> np.ndarray:
    """SI values of a range "LO:HI:N" (N values spaced logarithmically from LO to HI,
    LO < HI) or of a comma-separated increasing list "A,B,C"."""
    s = str(text).strip()
    if ":" in s:
        parts = s.split(":")
        if len(parts) != 3:
            raise InputError(f"{name}: {text!r} must be LO:HI:N, e.g. '1MPa:100MPa:20'")
        lo = parse_quantity(parts[0], kind, f"{name} (low end)")
        hi = parse_quantity(parts[1], kind, f"{name} (high end)")
        if not re.fullmatch(r"\s*\d+\s*", parts[2]) or int(parts[2]) < 2:
            raise InputError(f"{name}: the count in {text!r} must be an integer >= 2")
        if not lo < hi:
            si = DIMENSIONS[kind][1]
            raise InputError(f"{name}: the range {text!r} is in the wrong order (low end "
                             f"{lo:g} {si} >= high end {hi:g} {si})")
        return np.array([canonical(v) for v in np.geomspace(lo, hi, int(parts[2]))])
    values = np.array([parse_quantity(p, kind, name) for p in s.split(",") if p.strip()])
    if values.size == 0:
        raise InputError(f"{name}: no values in {text!r}")
    if np.any(np.diff(values) <= 0):
        raise InputError(f"{name}: the values {text!r} must increase strictly")
    return values


@dataclass(frozen=True)
class Scales:
    """SI values of the reference units: ``length`` L (m), ``modulus`` E* (Pa),
    ``viscosity`` eta (Pa s). Conversions of the dimensionless results (E* = 1, L = 1,
    eta = 1) to SI units."""

    length: float
    modulus: float
    viscosity: float

    def __post_init__(self) -> None:
        for name in ("length", "modulus", "viscosity"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"{name} scale must be a positive number, got {v!r}")

    @classmethod
    def of_scan(cls, surface: object, *, modulus: str | float,
                viscosity: str | float) -> Scales:
        """The scales of an imported scan (:func:`roughflow.scan.read_scan`): its own L
        (``surface.scan.length_scale``, the only length its leak rates may use), and E* and
        eta as SI numbers or with their units ("200GPa", "1mPa.s")."""
        scan = getattr(surface, "scan", None)
        if scan is None:
            raise InputError("Scales.of_scan needs an imported scan (roughflow.scan.read_scan "
                             "or `roughflow import`); a generated surface has no physical "
                             "length: give Scales(length=..., modulus=..., viscosity=...)")
        return cls(length=float(scan.length_scale),
                   modulus=parse_quantity(modulus, "pressure", "modulus"),
                   viscosity=parse_quantity(viscosity, "viscosity", "viscosity"))

    def pressure_to_si(self, p: ArrayLike) -> np.ndarray | float:
        """Pressure in E* -> Pa."""
        return np.asarray(p, dtype=float) * self.modulus

    def pressure_from_si(self, p: ArrayLike) -> np.ndarray | float:
        """Pressure in Pa -> E*."""
        return np.asarray(p, dtype=float) / self.modulus

    def length_to_si(self, u: ArrayLike) -> np.ndarray | float:
        """Length in L -> m."""
        return np.asarray(u, dtype=float) * self.length

    def conductance_to_si(self, sigma: ArrayLike) -> np.ndarray | float:
        """Conductance u^3/(12 eta) in L^3/eta -> m^3/(Pa s) (per unit width per unit
        pressure gradient)."""
        return np.asarray(sigma, dtype=float) * self.length**3 / self.viscosity

    def attrs(self) -> dict:
        """The dataset attributes that define the reference units (:func:`registry`)."""
        keys = {k: a for k, (a, _) in REFERENCE_ATTRS.items()}
        return {keys["ref_length"]: self.length, keys["ref_pressure"]: self.modulus,
                keys["ref_viscosity"]: self.viscosity}


def leak_rate(conductance_si: ArrayLike, *, fluid_pressure: float, seal_width: float,
              seal_length: float) -> np.ndarray | float:
    """Volume leak rate Q (m^3/s) through a seal of width ``seal_width`` (m, along the
    flow) and length ``seal_length`` (m, across it, e.g. the circumference) under the
    pressure drop ``fluid_pressure`` (Pa): Q = sigma_eff l dp / w (paper Eq. 4 with the
    effective conductance sigma_eff in m^3/(Pa s))."""
    return (np.asarray(conductance_si, dtype=float) * seal_length * fluid_pressure
            / seal_width)
