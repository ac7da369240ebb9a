"""Jobs of the sweep workflow: frozen parameter sets, their file names and CLI arguments.

A study block of the workflow config (``config/config.yaml``) expands into jobs with
:func:`expand_study`; every job knows its id (used as the file name), the arguments of
``roughflow scene <kind>`` that run it, its grid size (for resource estimates) and the
dataset coordinates it fills. Defaults come from :mod:`roughflow.defaults` and the job
dataclasses; :func:`study_defaults` gives those of a study block (the workflow schema is
tested against it).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
import shlex
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from roughflow import defaults
from roughflow.citation import LEAK_METHODS, contact_methods, threshold_methods
from roughflow.contact import check_contact_tol
from roughflow.datasets.sweep import param_key, rnd
from roughflow.defaults import (
    FLOW_STUDIES,
    STUDIES,
    STUDY_FIXED,
    STUDY_ONE_SIZE,
    STUDY_ONE_VALUE,
    THRESHOLD_STUDIES,
)
from roughflow.errors import (
    InputError,
    check_nu,
    require_installed,
    require_positive,
    require_seeds,
)
from roughflow.files import require_readable
from roughflow.surface import SurfaceSpec, paper_l_over_lambda_r

if TYPE_CHECKING:
    from collections.abc import Iterable

SWEEP_KEYS = ("model", "gamma", "hurst", "l_over_lambda_r", "eps_f", "points_per_lambda_s")


def fmt(v: float) -> str:
    """Short, file-name-safe text for a number (``0.0625``, ``5.65685``)."""
    return f"{float(v):.6g}"


def field_default(cls: type, name: str) -> Any:
    """The default of dataclass field ``name`` of ``cls`` (for argparse and schema checks)."""
    for f in fields(cls):
        if f.name == name:
            return f.default
    raise KeyError(f"{cls.__name__} has no field {name!r}")


@dataclass(frozen=True)
class SurfaceParams:
    """The sweep's dimensionless numbers of one surface family (unit-area cell).

    ``l_over_lambda_r`` None means the paper's default. ``eps_t`` is lambda_r in the easy
    direction over L: max(sqrt(gamma), 1/sqrt(gamma)) / (L / lambda_r).
    """

    gamma: float = defaults.GAMMA
    hurst: float = defaults.HURST
    l_over_lambda_r: float | None = None
    eps_f: float = defaults.EPS_F
    points_per_lambda_s: float = defaults.POINTS_PER_LAMBDA_S
    aspect: float = defaults.ASPECT

    def __post_init__(self) -> None:
        # every number is checked by building the spec (no allocation), so that a bad value
        # (gamma <= 0, an unresolvable size, ...) is refused here, naming it, and not as a
        # ZeroDivisionError inside a running job
        self.spec(0)

    @property
    def size(self) -> float:
        """L / lambda_r actually used."""
        if self.l_over_lambda_r is None:
            return paper_l_over_lambda_r(self.gamma)
        return float(self.l_over_lambda_r)

    @property
    def eps_t(self) -> float:
        s = math.sqrt(self.gamma)
        return rnd(max(s, 1.0 / s) / self.size)

    def spec(self, seed: int = 0) -> SurfaceSpec:
        """The surface spec (raises :class:`InputError` for unresolvable sizes)."""
        return SurfaceSpec.from_sweep(
            gamma=self.gamma, hurst=self.hurst, l_over_lambda_r=self.size, eps_f=self.eps_f,
            points_per_lambda_s=self.points_per_lambda_s, aspect=self.aspect, seed=int(seed),
        )

    def tag(self) -> str:
        return (f"g{fmt(self.gamma)}_H{fmt(self.hurst)}_L{fmt(self.size)}_f{fmt(self.eps_f)}"
                f"_p{fmt(self.points_per_lambda_s)}")

    def cli_args(self) -> list[str]:
        args = ["--gamma", repr(float(self.gamma)), "--hurst", repr(float(self.hurst)),
                "--eps-f", repr(float(self.eps_f)),
                "--points-per-lambda-s", repr(float(self.points_per_lambda_s))]
        if self.l_over_lambda_r is not None:
            args += ["--l-over-lambda-r", repr(float(self.l_over_lambda_r))]
        if self.aspect != 1.0:
            args += ["--aspect", repr(float(self.aspect))]
        return args


def _check_tol(name: str, value: float, maximum: float) -> float:
    v = require_positive(name, value)
    if v > maximum:
        raise InputError(f"{name} must be at most {maximum:g}, got {value!r}")
    return v


def _without_seeds(args: list[str]) -> tuple[str, ...]:
    """``cli_args`` without ``--seeds`` and its values (the job's settings)."""
    i = args.index("--seeds")
    j = i + 1
    while j < len(args) and not args[j].startswith("--"):
        j += 1
    return tuple(args[:i] + args[j:])


def _seed_tag(seeds: tuple[int, ...]) -> str:
    s = sorted(seeds)
    if s == list(range(s[0], s[-1] + 1)) and len(s) > 1:
        return f"s{s[0]}-{s[-1]}"
    return "s" + "_".join(str(v) for v in s)


class _SeedGroup:
    """A job over a group of seeds of one surface family (threshold and ladder jobs)."""

    @property
    def key(self) -> tuple:
        """The study-dataset cells this job fills, less the seed (:func:`param_key`)."""
        return param_key(self.surface, self.model)

    def settings(self) -> tuple[str, ...]:
        """Everything that defines the job except its seeds: jobs that share a
        :attr:`key` must have equal settings (else one study mixes two computations)."""
        return _without_seeds(self.cli_args())


@dataclass(frozen=True)
class ThresholdJob(_SeedGroup):
    """Percolation thresholds a_c*(x), a_c*(y) of ``seeds`` (threshold search, no flow)."""

    surface: SurfaceParams
    model: str = defaults.DEFAULT_MODEL
    seeds: tuple[int, ...] = (0,)
    tol: float = defaults.THRESHOLD_TOL
    contact_tol: float = defaults.THRESHOLD_CONTACT_TOL
    kind: str = field(default="threshold", init=False)

    def __post_init__(self) -> None:
        if self.model not in defaults.MODELS:
            raise InputError(f"model must be one of {defaults.MODELS}, got {self.model!r}")
        if self.model == "adhesive":
            raise InputError("threshold jobs take the elastic or bearing model, got 'adhesive' "
                             "(the threshold scene has no adhesion options; use "
                             "`roughflow threshold --model adhesive` on a surface file)")
        object.__setattr__(self, "seeds", require_seeds("seeds", self.seeds))
        _check_tol("tol", self.tol, defaults.THRESHOLD_TOL_MAX)
        check_contact_tol(self.contact_tol, "contact_tol")
        # the search's own check, at planning: a tol below one cell of the grid failed in
        # the job, after the other jobs of the run
        from roughflow.search.critical import check_threshold_tol

        spec = self.surface.spec(0)
        check_threshold_tol(self.tol, (spec.nx, spec.ny), self.model)
        if self.model == "bearing":
            # the exact bearing sweep solves no contact: contact_tol is unused, and kept at
            # its default so that a config's value neither reruns these jobs nor splits them
            object.__setattr__(self, "contact_tol", defaults.THRESHOLD_CONTACT_TOL)

    @property
    def job_id(self) -> str:
        return (f"{self.model}_{self.surface.tag()}_{_seed_tag(self.seeds)}"
                f"_t{fmt(self.tol)}_c{fmt(self.contact_tol)}")

    def cli_args(self) -> list[str]:
        return [self.kind, *self.surface.cli_args(), "--model", self.model,
                "--seeds", *[str(s) for s in self.seeds], "--tol", repr(float(self.tol)),
                "--contact-tol", repr(float(self.contact_tol))]


def _adhesion_args(adh: dict) -> dict:
    """LadderJob keywords from a config ``adhesion`` block (a Tabor parameter replaces the
    repulsion's default range)."""
    out = {"surface_energy_ratio": float(adh.get("surface_energy_ratio",
                                                 defaults.ADHESION_SURFACE_ENERGY_RATIO)),
           "repulsion": adh.get("repulsion", defaults.ADHESION_REPULSION)}
    if adh.get("tabor") is not None:
        if adh.get("range_over_lambda_s") is not None:
            raise InputError("adhesion: give range_over_lambda_s or tabor, not both "
                             f"(got {adh!r})")
        return {**out, "tabor": float(adh["tabor"])}
    rho = adh.get("range_over_lambda_s")
    return {**out, "range_over_lambda_s": None if rho is None else float(rho)}


@dataclass(frozen=True)
class LadderJob(_SeedGroup):
    """Contact along an area ladder, Reynolds flow along x and y, theory predictions."""

    surface: SurfaceParams
    model: str = defaults.DEFAULT_MODEL
    seeds: tuple[int, ...] = (0,)
    area_fractions: tuple[float, ...] = (0.1, 0.2, 0.3)
    a_c_star: float | None = None  # None: the model's defaults.A_C_STAR_THEORY
    a_c_star_alt: float | None = None
    area_tol: float = defaults.LADDER_AREA_TOL
    # adhesive model: the repulsion, gamma_s / v_ela^full and either the range rho / lambda_s
    # or the Tabor parameter (the defaults reproduce the paper's adhesive case,
    # contact.adhesion; range None without a Tabor parameter: the repulsion's default)
    surface_energy_ratio: float = defaults.ADHESION_SURFACE_ENERGY_RATIO
    range_over_lambda_s: float | None = None
    tabor: float | None = None
    repulsion: str = defaults.ADHESION_REPULSION
    kind: str = field(default="ladder", init=False)

    def __post_init__(self) -> None:
        if self.model not in defaults.MODELS:
            raise InputError(f"model must be one of {defaults.MODELS}, got {self.model!r}")
        object.__setattr__(self, "seeds", require_seeds("seeds", self.seeds))
        if self.a_c_star is None:
            object.__setattr__(self, "a_c_star", defaults.A_C_STAR_THEORY[self.model])
        a = self.area_fractions
        if not a or any(not (isinstance(v, (int, float)) and 0 < v < 1) for v in a):
            raise InputError(f"area_fractions must be contact areas in (0, 1), got {a!r}")
        if list(a) != sorted(set(a)):
            raise InputError(f"area_fractions must increase strictly, got {a!r}")
        for name in ("a_c_star", "a_c_star_alt"):
            value = getattr(self, name)
            if value is not None and not 0 < value < 1:
                raise InputError(f"{name} must lie in (0, 1), got {value!r}")
        if not (math.isfinite(self.area_tol)
                and 0 < self.area_tol <= defaults.LADDER_AREA_TOL_MAX):
            raise InputError(f"area_tol must lie in (0, {defaults.LADDER_AREA_TOL_MAX:g}], "
                             f"got {self.area_tol!r}")
        if self.model == "bearing":
            # the bearing ladder cuts each area exactly: area_tol is unused, and kept at its
            # default so that a config's value does not rerun the ladder's flow solves
            object.__setattr__(self, "area_tol", defaults.LADDER_AREA_TOL)
        if self.repulsion not in defaults.ADHESION_REPULSIONS:
            raise InputError(f"repulsion must be one of {defaults.ADHESION_REPULSIONS}, got "
                             f"{self.repulsion!r}")
        if self.tabor is not None and self.range_over_lambda_s is not None:
            raise InputError("adhesion takes range_over_lambda_s or tabor, not both, got "
                             f"range_over_lambda_s={self.range_over_lambda_s!r}, "
                             f"tabor={self.tabor!r}")
        if self.tabor is None and self.range_over_lambda_s is None:
            object.__setattr__(self, "range_over_lambda_s",
                               defaults.ADHESION_RANGE_OVER_LAMBDA_S[self.repulsion])
        for name in ("surface_energy_ratio", "range_over_lambda_s", "tabor"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise InputError(f"{name} must be a positive number, got {value!r}")
        if self.model != "adhesive":
            # the adhesion settings are the adhesive model's only: kept at their defaults
            # elsewhere, so that a study's adhesion block does not make its elastic ladder
            # differ from the same ladder of another study (refused as two jobs of one id)
            repulsion = defaults.ADHESION_REPULSION
            for name, value in (("surface_energy_ratio", defaults.ADHESION_SURFACE_ENERGY_RATIO),
                                ("tabor", None), ("repulsion", repulsion),
                                ("range_over_lambda_s",
                                 defaults.ADHESION_RANGE_OVER_LAMBDA_S[repulsion])):
                object.__setattr__(self, name, value)

    @property
    def job_id(self) -> str:
        # the ladder and theory settings enter through a short hash of the arguments
        digest = hashlib.sha1(" ".join(self.cli_args()).encode()).hexdigest()[:6]
        return f"{self.model}_{self.surface.tag()}_{_seed_tag(self.seeds)}_{digest}"

    def cli_args(self) -> list[str]:
        args = [self.kind, *self.surface.cli_args(), "--model", self.model,
                "--seeds", *[str(s) for s in self.seeds],
                "--area-fractions", *[repr(float(a)) for a in self.area_fractions],
                "--a-c-star", repr(float(self.a_c_star)),
                "--area-tol", repr(float(self.area_tol))]
        if self.a_c_star_alt is not None:
            args += ["--a-c-star-alt", repr(float(self.a_c_star_alt))]
        if self.model == "adhesive":
            args += ["--repulsion", self.repulsion,
                     "--surface-energy-ratio", repr(float(self.surface_energy_ratio))]
            args += (["--tabor", repr(float(self.tabor))] if self.tabor is not None else
                     ["--range-over-lambda-s", repr(float(self.range_over_lambda_s))])
        return args


@dataclass(frozen=True)
class ChannelsJob:
    """Fig. 1: an isotropic 0.5 x 2 cell and its gamma-stretched square version at a_c."""

    gamma: float = defaults.CHANNELS["gamma"]
    hurst: float = defaults.CHANNELS["hurst"]
    l_over_lambda_r: float = defaults.CHANNELS["l_over_lambda_r"]
    eps_f: float = defaults.CHANNELS["eps_f"]
    area_fraction: float = defaults.CHANNELS["area_fraction"]
    model: str = defaults.CHANNELS["model"]
    seed: int = defaults.CHANNELS["seed"]
    points_per_lambda_s: float = defaults.CHANNELS["points_per_lambda_s"]
    kind: str = field(default="channels", init=False)

    def __post_init__(self) -> None:
        if self.model not in ("elastic", "bearing"):
            raise InputError(f"the channels job takes the elastic or bearing model, got "
                             f"{self.model!r}")
        a = self.area_fraction
        if not (isinstance(a, (int, float)) and 0 < a < 1):
            raise InputError(f"area_fraction must lie in (0, 1), got {a!r}")
        require_seeds("seed", (self.seed,))
        self.surfaces()  # checks both cells (SurfaceParams)

    @property
    def job_id(self) -> str:
        return "channels"

    def surfaces(self) -> tuple[SurfaceParams, SurfaceParams]:
        """(isotropic rectangular cell with lx/ly = 1/gamma, stretched square cell)."""
        # the stretched cell first: it checks gamma (finite, > 0) before 1/gamma is taken
        aniso = SurfaceParams(gamma=self.gamma, hurst=self.hurst,
                              l_over_lambda_r=self.l_over_lambda_r, eps_f=self.eps_f,
                              points_per_lambda_s=self.points_per_lambda_s)
        try:
            iso = SurfaceParams(gamma=1.0, hurst=self.hurst,
                                l_over_lambda_r=self.l_over_lambda_r, eps_f=self.eps_f,
                                points_per_lambda_s=self.points_per_lambda_s,
                                aspect=1.0 / self.gamma)
        except InputError as exc:
            # its own message names the derived gamma=1 and aspect: name the given gamma
            raise InputError(f"gamma={self.gamma!r} gives an isotropic cell with lx/ly = "
                             f"1/gamma that does not fit: {exc}") from None
        return iso, aniso

    def cli_args(self) -> list[str]:
        return [self.kind, "--gamma", repr(float(self.gamma)), "--hurst", repr(float(self.hurst)),
                "--l-over-lambda-r", repr(float(self.l_over_lambda_r)),
                "--eps-f", repr(float(self.eps_f)),
                "--points-per-lambda-s", repr(float(self.points_per_lambda_s)),
                "--area-fraction", repr(float(self.area_fraction)), "--model", self.model,
                "--seeds", str(self.seed)]


#: Quantities of a leak question (``roughflow leak`` options), as unit strings; their kind.
LEAK_QUANTITIES = {"modulus": "pressure", "fluid_pressure": "pressure",
                   "viscosity": "viscosity", "seal_width": "length", "seal_length": "length"}
#: Import options of one scan in the measured study (``roughflow import`` options).
SCAN_KEYS = ("size", "unit", "height_unit", "detrend", "fill", "crop", "channel",
             "missing_value")


@dataclass(frozen=True)
class LeakJob:
    """One scan of the measured study: ``roughflow import`` then ``roughflow leak``.

    ``name`` labels the scan (file names, the ``scan`` coordinate); ``file`` is the scan;
    the import options (:data:`SCAN_KEYS`) apply where the file does not say; the leak
    question is given as unit strings (:data:`LEAK_QUANTITIES`, ``pressures`` as
    "LO:HI:N" or a list). Every quantity is parsed on construction (InputError naming the
    key), so a bad config stops the workflow before any job.
    """

    name: str
    file: str
    modulus: str
    pressures: str
    fluid_pressure: str
    viscosity: str
    seal_width: str
    seal_length: str
    size: str | None = None
    unit: str | None = None
    height_unit: str | None = None
    detrend: str = defaults.SCAN_DETREND
    fill: str = defaults.SCAN_FILL
    crop: str | None = None
    channel: str | None = None
    missing_value: float | None = None
    boundary: str = defaults.BOUNDARY
    kind: str = field(default="leak", init=False)

    def __post_init__(self) -> None:
        from roughflow.scan import check_crop, length_factor

        if not _NAME.fullmatch(str(self.name)):
            raise InputError(f"scan name must be letters, digits, '.', '_' or '-', got "
                             f"{self.name!r}")
        question_si(self.question())
        for key in ("unit", "height_unit"):  # as roughflow import reads them
            if getattr(self, key) is not None:
                length_factor(getattr(self, key), key)
        if self.size is not None:
            self.size_m()  # a bad length is refused here, not in its job
        check_crop(self.crop)
        if self.missing_value is not None:
            # YAML reads 1e38 (no sign in the exponent, no point) as a string
            try:
                value = None if isinstance(self.missing_value, bool) else \
                    float(self.missing_value)
            except (TypeError, ValueError):
                value = None
            if value is None or not math.isfinite(value):
                raise InputError(f"missing_value must be a finite number, got "
                                 f"{self.missing_value!r}")
            object.__setattr__(self, "missing_value", value)
        for key, choices in (("detrend", defaults.DETREND_MODES),
                             ("fill", defaults.FILL_METHODS),
                             ("boundary", defaults.BOUNDARY_METHODS)):
            if getattr(self, key) not in choices:
                raise InputError(f"{key} must be one of {choices}, got {getattr(self, key)!r}")

    @property
    def job_id(self) -> str:
        return self.name

    def size_m(self) -> tuple[float, float] | None:
        """The scan's size (lx, ly) in metres as ``roughflow import`` reads ``size``; None
        for numbers without ``unit`` (in the file's own unit, known once it is read)."""
        from roughflow.scan import is_number, scan_size

        if self.unit is None and any(is_number(p) for p in str(self.size).split(",")):
            return None
        return scan_size(self.size, self.unit)

    def import_args(self) -> list[str]:
        """``roughflow import`` options (after the scan file), in one spelling for one
        meaning (sizes in metres, units by their usual names), so that an edit of the
        config's units alone reruns nothing."""
        args = ["--detrend", self.detrend, "--fill", self.fill]
        heights = self.height_unit or self.unit
        if self.size is not None:
            size = self.size_m()
            args += ["--size", shlex.quote(str(self.size)) if size is None else
                     f"{size[0]!r}m,{size[1]!r}m"]
            if heights is not None:
                args += ["--height-unit", shlex.quote(_unit_name(heights))]
        else:
            for key in ("unit", "height_unit"):
                if getattr(self, key) is not None:
                    args += [f"--{key.replace('_', '-')}",
                             shlex.quote(_unit_name(getattr(self, key)))]
        for key in ("crop", "channel"):
            value = getattr(self, key)
            if value is not None:
                args += [f"--{key}", shlex.quote(str(value))]
        if self.missing_value is not None:  # "=": argparse takes "-999999" for an option
            args += [f"--missing-value={float(self.missing_value)!r}"]
        return args

    def cli_args(self) -> list[str]:
        """``roughflow leak`` options (after the surface file), every quantity in SI units
        (as for :meth:`import_args`: "200GPa" and "200000MPa" are one job)."""
        from roughflow.units import DIMENSIONS

        si = question_si(self.question())
        pressures = ",".join(f"{float(v)!r}Pa" for v in si["pressures"])
        args = ["--pressures", pressures, "--boundary", self.boundary, "--name", self.name]
        for key, kind in LEAK_QUANTITIES.items():
            args += [f"--{key.replace('_', '-')}",
                     shlex.quote(f"{si[key]!r}{DIMENSIONS[kind][1]}")]
        return args

    def question(self) -> dict[str, str]:
        """The leak question as the config gives it (:func:`question_si` reads it)."""
        return {key: getattr(self, key) for key in (*LEAK_QUANTITIES, "pressures")}


def question_si(values: dict) -> dict:
    """The leak question's quantities in SI units (``pressures`` an array), those of
    :data:`LEAK_QUANTITIES` and ``pressures`` that ``values`` gives; InputError naming the
    key otherwise."""
    from roughflow.units import parse_quantity, parse_range

    out = {key: parse_quantity(values[key], kind, key) for key, kind in LEAK_QUANTITIES.items()
           if values.get(key) is not None}
    if values.get("pressures") is not None:
        out["pressures"] = parse_range(values["pressures"], "pressure", "pressures")
    return out


#: Usual names of the length units a scan's heights come in (by metres per unit).
_UNIT_NAMES = {1.0: "m", 1e-3: "mm", 1e-6: "um", 1e-9: "nm"}


def _unit_name(unit: str) -> str:
    """``unit``'s usual name ("micrometer", "µm" and "micron" are "um"); others as given."""
    from roughflow.scan import length_factor

    return _UNIT_NAMES.get(length_factor(unit, "unit"), str(unit))


_NAME = re.compile(r"[A-Za-z0-9_.\-]+")

Job = ThresholdJob | LadderJob | ChannelsJob | LeakJob


def _grid(job: Job) -> tuple[int, int]:
    """(nx, ny) of one surface of the job (the stretched one of the channels job)."""
    if isinstance(job, LeakJob):
        raise InputError("a leak job's grid is that of its scan (known after the import)")
    spec = job.surfaces()[1].spec(job.seed) if isinstance(job, ChannelsJob) \
        else job.surface.spec(job.seeds[0])
    return spec.nx, spec.ny


def grid_points(job: Job) -> int:
    """Grid points of one surface of the job (for memory and runtime estimates)."""
    nx, ny = _grid(job)
    return nx * ny


def _as_list(v) -> list:
    return list(v) if isinstance(v, (list, tuple)) else [v]


def study_defaults(name: str) -> dict:
    """The value of every optional key of a study block when the config leaves it out."""
    if name == "channels":
        return {f.name: f.default for f in fields(ChannelsJob) if f.init}
    if name == defaults.MEASURED_STUDY:
        return {key: field_default(LeakJob, key) for key in ("detrend", "fill", "boundary")}
    common = {
        "gamma": [defaults.GAMMA], "hurst": [defaults.HURST], "eps_f": [defaults.EPS_F],
        "model": ["elastic"], "seeds_per_job": 1,
        "points_per_lambda_s": defaults.POINTS_PER_LAMBDA_S,
    }
    if name in THRESHOLD_STUDIES:
        return {**common, "l_over_lambda_r": [None],
                "tol": field_default(ThresholdJob, "tol"),
                "contact_tol": field_default(ThresholdJob, "contact_tol"),
                "fit": {"bootstrap": defaults.FIT_BOOTSTRAP, "nu": defaults.NU_PERCOLATION}}
    if name in FLOW_STUDIES:
        return {**common, "l_over_lambda_r": [defaults.FLOW_L_OVER_LAMBDA_R],
                "a_c_star": dict(defaults.A_C_STAR_THEORY),
                "a_c_star_alt": defaults.A_C_STAR_ALT,
                "area_tol": field_default(LadderJob, "area_tol"),
                "adhesion": {"repulsion": defaults.ADHESION_REPULSION,
                             "surface_energy_ratio": defaults.ADHESION_SURFACE_ENERGY_RATIO,
                             "range_over_lambda_s": defaults.ADHESION_RANGE_OVER_LAMBDA_S[
                                 defaults.ADHESION_REPULSION]}}
    raise InputError(f"unknown study {name!r}; known studies: {', '.join(STUDIES)}")


def _series(block: dict) -> list[dict]:
    base = {k: v for k, v in block.items() if k != "series"}
    series = block.get("series") or [{}]
    return [{**base, **s} for s in series]


def expand_study(name: str, block: dict) -> dict[str, Job]:
    """Jobs of one study block (already validated against the schema), keyed by job id.

    Keys the block leaves out take :func:`study_defaults`. List keys expand as a Cartesian
    product per series; seeds are grouped into ``seeds_per_job`` per job. Every job (and
    so every surface spec) is built here and the jobs are checked against each other
    (:func:`check_collisions`), so a bad value or a study whose jobs would overwrite each
    other's cells raises :class:`InputError` naming the study, series and values before any
    job runs.
    """
    _check_keys_apply(name, block)
    block = {**study_defaults(name), **block}
    if name == defaults.MEASURED_STUDY:
        return _expand_measured(block)
    if name == "channels":
        try:
            job = ChannelsJob(**block)
        except InputError as exc:
            raise InputError(f"config studies.{name}: {exc}") from None
        return {job.job_id: job}
    jobs: dict[str, Job] = {}
    for n, s in enumerate(_series(block)):
        where = f"config studies.{name}" + (f".series[{n}]" if block.get("series") else "")
        groups = seed_groups([int(v) for v in _as_list(s["seeds"])], int(s["seeds_per_job"]))
        ppl = float(s["points_per_lambda_s"])
        for model, gamma, hurst, size, eps_f in itertools.product(
            _as_list(s["model"]), _as_list(s["gamma"]), _as_list(s["hurst"]),
            _as_list(s["l_over_lambda_r"]), _as_list(s["eps_f"]),
        ):
            values = (f"model={model}, gamma={gamma:g}, hurst={hurst:g}, l_over_lambda_r="
                      f"{'null' if size is None else format(size, 'g')}, eps_f={eps_f:g}, "
                      f"points_per_lambda_s={ppl:g}")
            try:
                for g in groups:
                    job = _make_job(name, s, model, gamma, hurst, size, eps_f, ppl, g)
                    _add_job(jobs, job)
                if isinstance(job, LadderJob) and job.model == "adhesive":
                    check_adhesion_grid(job)  # one check per parameter set: seeds do not matter
            except InputError as exc:
                raise InputError(f"{where}: {values}: {exc}") from None
    check_collisions(name, jobs.values())
    _check_one_series(name, jobs.values())
    return jobs


#: Study keys that do not change the study's dataset: the fit's options (the fit rule's own
#: params) and a series' label. Left out of what the aggregation records, so that editing
#: them does not re-aggregate (and with a job file deleted, recompute that job).
NOT_AGGREGATED = ("fit", "label")


def aggregated_config(block: dict) -> str:
    """The study block an aggregated dataset records (its ``study_config``, JSON), without
    :data:`NOT_AGGREGATED`: the aggregation's Snakemake params."""
    def strip(d: dict) -> dict:
        return {k: ([strip(v) if isinstance(v, dict) else v for v in val]
                    if k == "series" and isinstance(val, list) else val)
                for k, val in d.items() if k not in NOT_AGGREGATED}

    return json.dumps(strip(block), sort_keys=True)


def seed_groups(seeds: list[int], per: int) -> list[tuple[int, ...]]:
    """The seeds of one parameter set, grouped into jobs by value: block ``seed // per``.

    By position (the first ``per`` seeds, then the next), removing one seed moved every later
    seed into another job, so Snakemake recomputed seeds it had (all 80 searches of a study
    for seed 0), and the config's order of seeds gave other jobs for the same seeds. By value,
    adding or removing a seed touches its own block's job only; ``[0, ..., 9]`` with ``per`` 5
    gives the blocks it gave before. Duplicates stay in their block, where the job refuses
    them."""
    blocks: dict[int, list[int]] = {}
    for seed in sorted(seeds):
        blocks.setdefault(seed // per, []).append(seed)
    return [tuple(block) for _, block in sorted(blocks.items())]


def check_adhesion_grid(job: LadderJob) -> None:
    """Refuse an adhesive ladder whose adhesive zone the grid pins
    (:func:`roughflow.contact.adhesion.check_zone`), from its spec's spectrum
    (:func:`roughflow.surface.spec_power`: the adhesion is the same on every seed's
    surface): at planning, not after the job made its surface and its reference flow
    solve. The message gives the range in the config's units."""
    from roughflow.contact.adhesion import ZONE_PINNED, adhesion_for_power, check_zone
    from roughflow.surface import spec_power

    spec = job.surface.spec(job.seeds[0])
    q, power = spec_power(spec)
    rho = None if job.range_over_lambda_s is None else job.range_over_lambda_s * spec.lambda_s
    adhesion = adhesion_for_power(q, power, gamma_over_v_full=job.surface_energy_ratio,
                                  tabor=job.tabor, range=rho, repulsion=job.repulsion)
    try:
        check_zone(adhesion, (spec.nx, spec.ny), spec.lx, spec.ly)
    except InputError as exc:
        spacing = max(spec.lx / spec.nx, spec.ly / spec.ny)
        zone_range = math.pi * math.sqrt(ZONE_PINNED * spacing * adhesion.surface_energy) / 2
        raise InputError(
            f"adhesion (surface_energy_ratio {job.surface_energy_ratio:g}, "
            + (f"tabor {job.tabor:g}" if job.tabor is not None else
               f"range_over_lambda_s {job.range_over_lambda_s:g}")
            + f"): {exc}; in the config's units the range is {adhesion.range / spec.lambda_s:.3g}"
            f" lambda_s and must be at least {zone_range / spec.lambda_s:.3g} lambda_s "
            "(adhesion.range_over_lambda_s), or points_per_lambda_s larger") from None


def _add_job(jobs: dict[str, Job], job: Job) -> None:
    """Add ``job`` under its id; the same job twice is one job, but two different jobs with
    one id (values equal to the 6 digits of the id) would silently drop the second."""
    other = jobs.setdefault(job.job_id, job)
    if other != job:
        raise InputError(f"two different jobs get the id {job.job_id!r} (their values agree "
                         "to the 6 significant digits of job ids): make them differ more")


def _check_one_series(name: str, jobs) -> None:
    """Refuse at planning a study whose figure or fit would refuse its dataset after every
    job ran: several values of a parameter it draws one series of."""
    from roughflow.datasets.sweep import PARAM_DIMS

    if name in STUDY_ONE_SIZE:  # one system size per point
        sizes: dict[tuple, set] = {}
        for job in jobs:
            key = dict(zip(PARAM_DIMS, job.key, strict=True))
            eps_t = key.pop("eps_t")
            sizes.setdefault(tuple(key.items()), set()).add(eps_t)
        for point, found in sizes.items():
            if len(found) > 1:
                shown = ", ".join(f"{d}={v:g}" if isinstance(v, float) else f"{d}={v}"
                                  for d, v in point)
                raise InputError(f"config studies.{name}: its figure shows one system size "
                                 f"per point, {shown} has {len(found)} (eps_t "
                                 f"{', '.join(f'{e:g}' for e in sorted(found))}); "
                                 "threshold_vs_size draws the sizes")
    dims = STUDY_ONE_VALUE.get(name)
    if dims is None:
        return
    per_model = name in FLOW_STUDIES
    seen: dict[str, dict[str, set]] = {}
    for job in jobs:
        key = dict(zip(PARAM_DIMS, job.key, strict=True))
        values = seen.setdefault(key["model"] if per_model else "", {})
        for dim in dims:
            values.setdefault(dim, set()).add(key[dim])
    for model, values in seen.items():
        for dim, found in values.items():
            if len(found) > 1:
                where = f" for model {model}" if per_model else ""
                shown = ", ".join(f"{v:g}" if isinstance(v, float) else str(v)
                                  for v in sorted(found, key=str))
                raise InputError(f"config studies.{name}: its figure shows one {dim}"
                                 f"{where}, the study has {len(found)}: {shown}")


def _check_keys_apply(name: str, block: dict) -> None:
    """Refuse keys of a study block that nothing would use (they were silently ignored)."""
    where = f"config studies.{name}"
    if name in THRESHOLD_STUDIES:
        for n, s in enumerate(block.get("series") or []):
            if "area_fraction" in s:
                raise InputError(f"{where}.series[{n}]: area_fraction is a key of the flow "
                                 "studies (their contact-area ladder); a threshold study "
                                 "searches a_c*")
        if "fit" in block:
            if name != "threshold_vs_size":
                raise InputError(f"{where}: fit applies to threshold_vs_size only (its "
                                 "finite-size-scaling fit); this study runs no fit")
            if "nu" in block["fit"]:
                try:
                    check_nu(block["fit"]["nu"])
                except InputError as exc:
                    raise InputError(f"{where}.fit: {exc}") from None
    if name in FLOW_STUDIES:
        models = set(_as_list(block.get("model", study_defaults(name)["model"])))
        for s in block.get("series") or []:
            models |= set(_as_list(s.get("model", [])))
        if "adhesion" in block and "adhesive" not in models:
            raise InputError(f"{where}: adhesion applies to the adhesive model, which this "
                             f"study does not run (models: {', '.join(sorted(models))})")
        unused = sorted(set(block.get("a_c_star") or {}) - models)
        if unused:
            raise InputError(f"{where}: a_c_star of {', '.join(unused)}, a model this study "
                             f"does not run (models: {', '.join(sorted(models))})")
    fixed, other = STUDY_FIXED.get(name, ({}, None))
    for key, value in fixed.items():
        values = set(_as_list(block.get(key, [value])))
        for s in block.get("series") or []:
            values |= set(_as_list(s.get(key, [])))
        if values - {value}:
            raise InputError(f"{where}: this study takes {key} = {value:g}, got "
                             f"{sorted(values)} (other values: {other})")


def expand_studies(studies: dict) -> dict[str, Job]:
    """Jobs of every study of a config's ``studies`` block, keyed by job id (a job that
    two studies share, such as an H = 0.8 threshold point, appears once)."""
    return pool_jobs({name: expand_study(name, block) for name, block in studies.items()})


def pool_jobs(jobs_by_study: dict[str, dict[str, Job]]) -> dict[str, Job]:
    """The jobs of several studies keyed by job id, each once: a job that two studies
    share runs once. Two different jobs with one id (values that agree to the 6
    significant digits of job ids) raise :class:`InputError` naming both studies and how
    the jobs differ: the second would be dropped."""
    pool: dict[str, Job] = {}
    owner: dict[str, str] = {}
    for study, jobs in jobs_by_study.items():
        for job_id, job in jobs.items():
            other = pool.setdefault(job_id, job)
            owner.setdefault(job_id, study)
            if other != job:
                diff = "; ".join(f"{name} {a!r} vs {b!r}" for name, a, b in _differences(other,
                                                                                          job))
                raise InputError(
                    f"config studies.{owner[job_id]} and studies.{study}: two different jobs "
                    f"get the id {job_id!r} ({diff}; the values agree to the 6 significant "
                    "digits of job ids): make them equal, or differ more")
    return pool


def _differences(a, b, prefix: str = "") -> list[tuple[str, object, object]]:
    """(field, value in a, value in b) where two jobs (dataclasses, nested) differ."""
    if type(a) is not type(b) or not hasattr(a, "__dataclass_fields__"):
        return [(prefix.rstrip(".") or "kind", a, b)] if a != b else []
    out = []
    for f in fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if x != y:
            out += (_differences(x, y, f"{prefix}{f.name}.")
                    if hasattr(x, "__dataclass_fields__") else [(prefix + f.name, x, y)])
    return out


def _expand_measured(block: dict) -> dict[str, Job]:
    """One :class:`LeakJob` per scan; a scan entry's keys override the study's."""
    study = defaults.MEASURED_STUDY
    shared = {k: v for k, v in block.items() if k != "scans"}
    try:  # a bad study-level value is the study's, not its first scan's
        question_si(shared)
    except InputError as exc:
        raise InputError(f"config studies.{study}: {exc}") from None
    jobs: dict[str, Job] = {}
    if block["scans"]:  # the import jobs would fail on it, after the other studies' jobs
        try:
            require_installed(defaults.SCAN_READER, "reading scans", defaults.SCAN_READER_EXTRA)
        except InputError as exc:
            raise InputError(f"config studies.{study}: {exc}") from None
    for entry in block["scans"]:
        args = {**shared, **entry}
        name = args.get("name") or Path(str(args["file"])).stem
        args["name"] = name
        # the import job would fail on it, after the other studies' jobs
        require_readable(Path(str(args["file"])),
                         f"config studies.{study}, scan {name!r}: file {args['file']!r}",
                         missing=f" (paths are relative to {Path.cwd()})")
        if name in jobs:
            raise InputError(f"config studies.{study}: two scans are named {name!r}")
        try:
            jobs[name] = LeakJob(**args)
        except InputError as exc:
            raise InputError(f"config studies.{study}, scan {name!r}: {exc}") from None
    return jobs



def _make_job(name: str, s: dict, model, gamma, hurst, size, eps_f, ppl, seeds) -> Job:
    size = paper_l_over_lambda_r(float(gamma)) if size is None else float(size)
    p = SurfaceParams(gamma=float(gamma), hurst=float(hurst), l_over_lambda_r=size,
                      eps_f=float(eps_f), points_per_lambda_s=ppl)
    if name in THRESHOLD_STUDIES:
        return ThresholdJob(surface=p, model=model, seeds=seeds, tol=float(s["tol"]),
                            contact_tol=float(s["contact_tol"]))
    stars = {**defaults.A_C_STAR_THEORY, **s["a_c_star"]}
    alt = s["a_c_star_alt"]
    return LadderJob(
        surface=p, model=model, seeds=seeds,
        area_fractions=tuple(sorted(float(a) for a in s["area_fraction"])),
        a_c_star=float(stars[model]), a_c_star_alt=None if alt is None else float(alt),
        area_tol=float(s["area_tol"]), **_adhesion_args(s["adhesion"]),
    )


def _options(args: tuple[str, ...]) -> dict[str, str]:
    """``--flag value ...`` -> {flag: "value ..."} (for messages)."""
    out: dict[str, list[str]] = {}
    flag = ""
    for a in args:
        if a.startswith("--"):
            flag = a
            out[flag] = []
        else:
            out.setdefault(flag, []).append(a)
    return {k: " ".join(v) for k, v in out.items()}


def describe_key(key: tuple) -> str:
    """``model=elastic, gamma=1, ...`` for a :attr:`ThresholdJob.key`."""
    from roughflow.datasets.sweep import PARAM_DIMS

    return ", ".join(f"{d}={v:g}" if isinstance(v, float) else f"{d}={v}"
                     for d, v in zip(PARAM_DIMS, key, strict=True))


def check_collisions(study: str, jobs: Iterable[Job]) -> None:
    """Refuse jobs of one study that would fill the same cells of its dataset.

    Jobs with the same :attr:`~ThresholdJob.key` (model, gamma, hurst, eps_t, eps_f) are
    stacked along ``seed`` by the aggregation; they must have the same settings (grid
    resolution, tolerances, ladder, ...: else the study would mix two computations, and the
    settings that are variables, such as ``points_per_lambda_s``, would collide) and
    distinct seeds (else the aggregation would duplicate or drop a seed).
    """
    seen: dict[tuple, list] = {}
    for job in jobs:
        if isinstance(job, ChannelsJob):
            continue
        for other in seen.get(job.key, []):
            if other.settings() != job.settings():
                a, b = _options(other.settings()), _options(job.settings())
                diff = "; ".join(f"{k} {a.get(k, '(none)')} vs {b.get(k, '(none)')}"
                                 for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k))
                raise InputError(
                    f"config studies.{study}: two jobs fill the same cells "
                    f"({describe_key(job.key)}) with different settings ({diff}); the "
                    "dataset has no dimension for them: put them in different studies or "
                    "give them different parameters")
            common = sorted(set(job.seeds) & set(other.seeds))
            if common:
                raise InputError(
                    f"config studies.{study}: seeds {common} of {describe_key(job.key)} are "
                    f"computed by two jobs ({other.job_id} and {job.job_id}); every seed "
                    "may appear once per parameter set (check overlapping series)")
        seen.setdefault(job.key, []).append(job)


def job_methods(job: Job) -> tuple[str, ...]:
    """The methods a job uses (names of :data:`roughflow.citation.METHODS`)."""
    if isinstance(job, LeakJob):
        return LEAK_METHODS
    if isinstance(job, ThresholdJob):
        return ("surface", *threshold_methods(job.model))
    contact = contact_methods(job.model,
                              repulsion=job.repulsion if isinstance(job, LadderJob) else None)
    corrected = ("perimeter",) if job.model == "elastic" else ()
    if isinstance(job, LadderJob):
        return ("surface", *contact, "percolation", "reynolds", "bruggeman", "closed_form",
                *corrected)
    return ("surface", *contact, "percolation")
