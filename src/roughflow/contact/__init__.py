"""Elastic contact of a rigid rough surface with a flat elastic half-space (paper Sect. 2.2).

``solve`` is the entry point (``prepare``: its per-surface set-up, built once for many
solves; ``workspace``: arrays reused by a sequence of solves that keep little of each);
``ContactResult`` holds the gap field and the scalars; ``Adhesion`` parameterises the
short-range adhesive model (docs/physics.md Sect. 3.3); ``ContactLaw`` is the small-load
law a_c(p) that load searches start from.
"""

from ._result import ContactResult
from .adhesion import Adhesion, adhesion_summary, tabor_parameter
from .cg import check_hardness, require_below_hardness
from .elastic import cell_compliance, full_contact_energy
from .law import ContactLaw
from .solve import (
    METHODS,
    MODELS,
    check_contact_tol,
    check_pressure_scale,
    check_resolved_load,
    prepare,
    resolved_load_floor,
    solve,
    workspace,
)

__all__ = [
    "METHODS",
    "MODELS",
    "Adhesion",
    "ContactLaw",
    "ContactResult",
    "adhesion_summary",
    "cell_compliance",
    "check_contact_tol",
    "check_hardness",
    "check_pressure_scale",
    "check_resolved_load",
    "full_contact_energy",
    "prepare",
    "require_below_hardness",
    "resolved_load_floor",
    "solve",
    "tabor_parameter",
    "workspace",
]
