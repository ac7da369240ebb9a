"""Effective-medium and contact theory (paper Sect. 2.3, Eq. 5-16).

* ``bruggeman`` (isotropic, Eq. 5-6), ``bruggeman_anisotropic`` (Persson's Eq. 7-8 and
  the corrected Eq. 9), ``noncontact_decomposition`` (Eq. 10-13), ``local_conductivity``;
* ``closed_form`` (Eq. 16: elastic, adhesive, bearing);
* ``persson_area``, ``persson_mean_gap``, ``persson_elastic_energy``,
  ``predict_conductance`` (Persson theory from the height spectrum);
* ``conductivity_peklenik`` (anisotropy of the local conductivity);
* ``gap_theory``: all of the above that a single gap field determines, in one call.

Units: E* = 1, lengths in L, eta = 1, conductivities u^3/(12 eta) in L^3/eta.
See ``docs/theory.md``.
"""

from .closed_form import EXPONENTS, KINDS, closed_form, criticality_factor
from .effective_medium import (
    FORMS,
    AnisotropicResult,
    BruggemanResult,
    Medium,
    NonContact,
    bruggeman,
    bruggeman_anisotropic,
    bruggeman_gap,
    effective_dimension,
    local_conductivity,
    medium,
    noncontact_decomposition,
)
from .gap import GapTheory, gap_theory
from .peklenik import (
    autocorrelation,
    conductivity_peklenik,
    correlation_lengths,
    peklenik_number,
)
from .persson import (
    DiscreteSpectrum,
    PerssonPrediction,
    discrete_spectrum,
    persson_area,
    persson_elastic_energy,
    persson_mean_gap,
    persson_u0,
    predict_conductance,
)

__all__ = [
    "EXPONENTS",
    "FORMS",
    "KINDS",
    "GapTheory",
    "AnisotropicResult",
    "BruggemanResult",
    "DiscreteSpectrum",
    "Medium",
    "NonContact",
    "PerssonPrediction",
    "autocorrelation",
    "bruggeman",
    "bruggeman_anisotropic",
    "bruggeman_gap",
    "closed_form",
    "conductivity_peklenik",
    "correlation_lengths",
    "criticality_factor",
    "discrete_spectrum",
    "effective_dimension",
    "gap_theory",
    "local_conductivity",
    "medium",
    "noncontact_decomposition",
    "peklenik_number",
    "persson_area",
    "persson_elastic_energy",
    "persson_mean_gap",
    "persson_u0",
    "predict_conductance",
]
