"""Jobs of the sweep workflow: frozen parameter sets, their file names and CLI arguments.

A study block of the workflow config (``config/config.yaml``) expands into jobs with
:func:`roughflow.scenes.expand.expand_study`; every job knows its id (used as the file name),
the arguments of ``roughflow scene <kind>`` that run it, its grid size (for resource
estimates) and the dataset coordinates it fills. Defaults come from :mod:`roughflow.defaults`
and the job dataclasses; :func:`roughflow.scenes.expand.study_defaults` gives those of a study
block (the workflow schema is tested against it).
"""

from __future__ import annotations

import hashlib
import math
import re
import shlex
from dataclasses import dataclass, field, fields
from typing import Any

from roughflow import defaults
from roughflow.citation import LEAK_METHODS, contact_methods, threshold_methods
from roughflow.contact import check_contact_tol
from roughflow.datasets.sweep import param_key, rnd
from roughflow.errors import InputError, require_positive, require_seeds
from roughflow.surface import SurfaceSpec, paper_l_over_lambda_r

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
