"""Elastic contact of a rigid rough surface with a flat elastic half-space (paper Sect. 2.2).

``solve`` is the entry point; ``ContactResult`` holds the gap field and the scalars;
``Adhesion`` parameterises the short-range adhesive model (physics.md 3.3).
"""

from ._result import ContactResult
from .adhesion import Adhesion, adhesion_summary, tabor_parameter
from .elastic import full_contact_energy
from .solve import DEFAULT_TOL, METHODS, MODELS, solve

__all__ = [
    "DEFAULT_TOL",
    "METHODS",
    "MODELS",
    "Adhesion",
    "ContactResult",
    "adhesion_summary",
    "full_contact_energy",
    "solve",
    "tabor_parameter",
]
