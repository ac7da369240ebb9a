"""The kinds of dataset roughflow reads, recognised by their variables and attributes.

Every command that reads a file checks that it is of the kind it expects before any work
starts (``roughflow.io.read_dataset``), and names what it found otherwise. A kind lists the
variables it needs with their dimensions (``None``: any) and the attributes it needs;
``any_of`` is a group of variables of which at least one must be present; ``finite`` lists
variables whose values must all be finite (the fields the solvers start from).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from roughflow.errors import InputError

from .sweep import PARAM_DIMS

if TYPE_CHECKING:
    import xarray as xr


@dataclass(frozen=True)
class Kind:
    """What a dataset of one kind must hold; ``what`` names it in messages."""

    what: str
    variables: dict[str, tuple[str, ...] | None] = field(default_factory=dict)
    attrs: tuple[str, ...] = ()
    any_of: tuple[str, ...] = ()
    finite: tuple[str, ...] = ()

    def problems(self, ds: xr.Dataset, *, values: bool = True) -> list[str]:
        """Why ``ds`` is not of this kind (empty when it is); ``values=False``: its layout
        only (variables, dimensions, attributes), not the finite values."""
        out = []
        for name, dims in self.variables.items():
            if name not in ds.variables:
                out.append(f"no {name!r} variable")
            elif dims is not None and tuple(ds[name].dims) != dims:
                out.append(f"{name!r} has dimensions {tuple(ds[name].dims)}, expected {dims}")
        if self.any_of and not any(n in ds.variables for n in self.any_of):
            out.append(f"none of the variables {', '.join(map(repr, self.any_of))}")
        out += [f"no {a!r} attribute" for a in self.attrs if a not in ds.attrs]
        for name in self.finite if values else ():
            if name in ds.variables and not out:
                bad = int((~np.isfinite(np.asarray(ds[name].values, dtype=float))).sum())
                if bad:
                    out.append(f"{name!r} has {bad} non-finite values")
        return out


_JOB = (*PARAM_DIMS, "seed")
KINDS: dict[str, Kind] = {
    # the most specific kinds first: the first kind a dataset satisfies names it in messages
    "threshold_job": Kind("a threshold job file (roughflow scene threshold)",
                          {"a_c_star": (*_JOB, "axis")}, ("job_id", "scene")),
    "ladder_job": Kind("a ladder job file (roughflow scene ladder)",
                       {"sigma": (*_JOB, "step", "axis"),
                        "area_fraction": (*_JOB, "step")}, ("job_id", "scene")),
    "threshold_study": Kind("a threshold study dataset (roughflow aggregate)",
                            {"a_c_star": (*_JOB, "axis")}, ("n_jobs",)),
    "ladder_study": Kind("a flow study dataset (roughflow aggregate)",
                         {"sigma": (*_JOB, "step", "axis"),
                          "area_fraction": (*_JOB, "step")}, ("n_jobs",)),
    "leak_study": Kind("a measured study dataset (roughflow aggregate)",
                       {"leak_rate": ("scan", "pressure", "axis")}, ("n_jobs",)),
    "leak_job": Kind("a leak file (roughflow leak)",
                     {"leak_rate": ("scan", "pressure", "axis")}, ("boundary",)),
    "channels": Kind("a channels dataset (roughflow scene channels)",
                     {"phase_iso": None, "phase_aniso": None, "heights_iso": None}),
    "fit": Kind("a fit file (roughflow fit)", {"a_star": ("group", "fit", "nu_mode")}),
    "flow": Kind("a flow file (roughflow flow)", {"contact": ("x", "y")},
                 any_of=("sigma_x", "sigma_y")),
    "threshold": Kind("a threshold file (roughflow threshold)", {"a_c_star": ("axis",)}),
    # a contact file holds the surface's heights too, so it also reads as a surface
    "contact": Kind("a contact file (roughflow contact)", {"gap": ("x", "y")}, ("lx", "ly"),
                    finite=("gap",)),
    "surface": Kind("a surface file (roughflow surface)", {"heights": ("x", "y")},
                    ("lx", "ly"), finite=("heights",)),
    "gap": Kind("a file with a gap field (roughflow contact)", {"gap": None}, finite=("gap",)),
}

#: The kind of dataset each study's figure reads.
STUDY_KINDS = {"channels": "channels", "threshold_vs_gamma": "threshold_study",
               "threshold_vs_size": "threshold_study", "threshold_vs_hurst": "threshold_study",
               "flow_isotropic": "ladder_study", "flow_anisotropic": "ladder_study",
               "measured": "leak_study"}


def kinds_of(ds: xr.Dataset) -> list[str]:
    """Every kind ``ds`` satisfies (most specific kinds may come with general ones)."""
    return [name for name, kind in KINDS.items() if not kind.problems(ds)]


def check_kind(ds: xr.Dataset, kinds: str | tuple[str, ...], source: str) -> str:
    """Return the first of ``kinds`` that ``ds`` (read from ``source``) is, or raise
    :class:`InputError` saying what is missing and what the dataset looks like."""
    kinds = (kinds,) if isinstance(kinds, str) else tuple(kinds)
    for k in kinds:
        if not KINDS[k].problems(ds):
            return k
    first = KINDS[kinds[0]]
    wanted = " or ".join(KINDS[k].what for k in kinds)
    # a file of the wanted layout whose values are bad is not another kind of file
    laid_out = any(not KINDS[k].problems(ds, values=False) for k in kinds)
    looks = [] if laid_out else [KINDS[k].what for k in kinds_of(ds) if k != "gap"]
    hint = f"; it looks like {looks[0]}" if looks else ""
    raise InputError(f"{source} is not {wanted}: {'; '.join(first.problems(ds))}{hint}")
