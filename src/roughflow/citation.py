"""The publications behind roughflow's methods: the one machine-readable list.

``roughflow.references()`` returns them and ``roughflow cite`` prints them (all, per
method, or those a dataset records in its
``references`` attribute) as text, BibTeX or CFF; the reference list of docs/physics.md is
this list in Markdown (``roughflow cite --format markdown``, checked by
tests/test_citation.py), and CITATION.cff is ``roughflow cite --format cff``.

:data:`METHODS` says which references each method rests on; every command records the
keys of the methods it used in the ``references`` attribute of its output
(:mod:`roughflow.provenance`).
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Collection

__all__ = ["Reference", "REFERENCES", "METHODS", "contact_methods", "threshold_methods",
           "LEAK_METHODS", "references", "keys_for", "markdown", "cff"]


@dataclass(frozen=True)
class Reference:
    """One publication; ``key`` is the label docs/physics.md cites it by."""

    key: str
    authors: tuple[str, ...]
    title: str
    journal: str
    year: int
    doi: str
    volume: str = ""
    pages: str = ""
    note: str = ""

    @property
    def author_list(self) -> str:
        """``A. B, C. D et al.``"""
        names = ", ".join(a for a in self.authors if a != "et al.")
        return names + (" et al." if "et al." in self.authors else "")

    @property
    def venue(self) -> str:
        return self.journal + (f" {self.volume}" if self.volume else "") + \
            (f", {self.pages}" if self.pages else "")

    def text(self) -> str:
        """``authors, title, venue (year), doi:... (note).``"""
        note = f" ({self.note})" if self.note else ""
        return (f"{self.author_list}, {self.title}, {self.venue} ({self.year}), "
                f"doi:{self.doi}{note}.")

    def bibtex(self) -> str:
        preprint = self.journal.startswith("arXiv:")
        fields = {"author": " and ".join(a.replace("et al.", "others") for a in self.authors),
                  "title": "{" + self.title + "}", "year": str(self.year), "doi": self.doi}
        if preprint:
            fields["eprint"] = self.journal.removeprefix("arXiv:")
            fields["archiveprefix"] = "arXiv"
        else:
            fields.update({"journal": self.journal, "volume": self.volume,
                           "pages": self.pages})
        body = ",\n".join(f"  {k} = {{{v}}}" for k, v in fields.items() if v)
        return f"@{'misc' if preprint else 'article'}{{{self.key},\n{body}\n}}"

    def cff(self) -> dict:
        """A CITATION.cff ``references`` entry."""
        authors = []
        for a in self.authors:
            if a == "et al.":
                authors.append({"name": "et al."})
                continue
            given, _, family = a.rpartition(" ")
            authors.append({"family-names": family, "given-names": given})
        out = {"type": "article", "title": self.title, "authors": authors,
               "year": self.year, "doi": self.doi, "journal": self.journal}
        if self.volume:
            out["volume"] = int(self.volume) if self.volume.isdigit() else self.volume
        if self.pages:
            out["start"] = self.pages
        return out


REFERENCES = {r.key: r for r in (
    Reference("WM21", ("A. Wang", "M. H. Müser"),
              "Percolation and Reynolds flow in elastic contacts of isotropic and anisotropic, "
              "randomly rough surfaces", "Tribol. Lett.", 2021, "10.1007/s11249-020-01378-7",
              volume="69", note="arXiv:2010.13470"),
    Reference("CM06", ("C. Campañá", "M. H. Müser"),
              "Practical Green's function approach to the simulation of elastic semi-infinite "
              "solids", "Phys. Rev. B", 2006, "10.1103/PhysRevB.74.075420", volume="74",
              pages="075420"),
    Reference("ZMM19", ("Y. Zhou", "M. Moseler", "M. H. Müser"),
              "Solution of boundary-element problems using the fast-inertial-relaxation-engine "
              "method", "Phys. Rev. B", 2019, "10.1103/PhysRevB.99.144103", volume="99",
              pages="144103"),
    Reference("B06", ("E. Bitzek", "P. Koskinen", "F. Gähler", "M. Moseler", "P. Gumbsch"),
              "Structural relaxation made simple", "Phys. Rev. Lett.", 2006,
              "10.1103/PhysRevLett.97.170201", volume="97", pages="170201"),
    Reference("G20", ("J. Guénolé", "et al."),
              "Assessment and optimization of the fast inertial relaxation engine (FIRE) for "
              "energy minimization in atomistic simulations and its implementation in LAMMPS",
              "Comput. Mater. Sci.", 2020, "10.1016/j.commatsci.2020.109584", volume="175",
              pages="109584"),
    Reference("PK99", ("I. A. Polonsky", "L. M. Keer"),
              "A numerical method for solving rough contact problems based on the multi-level "
              "multi-summation and conjugate gradient techniques", "Wear", 1999,
              "10.1016/S0043-1648(99)00113-1", volume="231", pages="206"),
    Reference("A07", ("A. Almqvist", "F. Sahlin", "R. Larsson", "S. Glavatskih"),
              "On the dry elasto-plastic contact of nominally flat surfaces", "Tribol. Int.",
              2007, "10.1016/j.triboint.2005.11.008", volume="40", pages="574"),
    Reference("HK76", ("J. Hoshen", "R. Kopelman"), "Percolation and cluster distribution",
              "Phys. Rev. B", 1976, "10.1103/PhysRevB.14.3438", volume="14", pages="3438"),
    Reference("Br35", ("D. A. G. Bruggeman",),
              "Berechnung verschiedener physikalischer Konstanten von heterogenen Substanzen",
              "Ann. Phys.", 1935, "10.1002/andp.19354160705", volume="416", pages="636"),
    Reference("P01", ("B. N. J. Persson",), "Theory of rubber friction and contact mechanics",
              "J. Chem. Phys.", 2001, "10.1063/1.1388626", volume="115", pages="3840"),
    Reference("YP08", ("C. Yang", "B. N. J. Persson"),
              "Contact mechanics: contact area and interfacial separation from small contact "
              "to full contact", "J. Phys.: Condens. Matter", 2008,
              "10.1088/0953-8984/20/21/215214", volume="20", pages="215214"),
    Reference("D12", ("W. B. Dapp", "A. Lücke", "B. N. J. Persson", "M. H. Müser"),
              "Self-affine elastic contacts: percolation and leakage", "Phys. Rev. Lett.", 2012,
              "10.1103/PhysRevLett.108.244301", volume="108", pages="244301"),
    Reference("DM15", ("W. B. Dapp", "M. H. Müser"),
              "Contact mechanics of and Reynolds flow through saddle points: on the coalescence "
              "of contact patches and the leakage rate through near-critical constrictions",
              "EPL", 2015, "10.1209/0295-5075/109/44001", volume="109", pages="44001"),
    Reference("DM16", ("W. B. Dapp", "M. H. Müser"), "Fluid leakage near the percolation "
              "threshold", "Sci. Rep.", 2016, "10.1038/srep19513", volume="6", pages="19513"),
    Reference("P12", ("B. N. J. Persson", "et al."),
              "Elastic contact mechanics: percolation of the contact area and fluid squeeze-out",
              "Eur. Phys. J. E", 2012, "10.1140/epje/i2012-12005-2", volume="35", pages="5"),
    Reference("P20", ("B. N. J. Persson",),
              "Fluid flow at the interface between elastic solids with anisotropic surface "
              "roughness", "arXiv:2003.02007", 2020, "10.48550/arXiv.2003.02007"),
    Reference("Y17", ("V. A. Yastrebov", "G. Anciaux", "J.-F. Molinari"),
              "On the accurate computation of the true contact-area in mechanical contact of "
              "random rough surfaces", "Tribol. Int.", 2017, "10.48550/arXiv.1701.02727",
              volume="114", pages="161",
              note="arXiv:1701.02727; the perimeter correction of `roughflow.accuracy`, "
                   "docs/accuracy.md"),
)}

#: The references each method rests on (docs/physics.md says where each is used).
METHODS = {
    "surface": ("WM21",),                    # random-phase surfaces, Peklenik anisotropy
    "gfmd": ("CM06", "ZMM19", "PK99"),       # GFMD, mass weighting, constrained CG (hard wall)
    "fire": ("B06",),                        # FIRE: the hard wall with adhesion
    "cg": ("PK99",),                         # constrained conjugate gradients
    "hardness": ("A07",),                    # pressure capped at the hardness (cg)
    "adhesion": ("WM21",),                   # the paper's short-range adhesion
    "bearing": ("WM21",),                    # bearing-area (overlap) model
    "percolation": ("HK76", "D12", "WM21"),  # cluster labels, a_c*
    "perimeter": ("Y17",),                   # perimeter correction of the contact area
    "reynolds": ("WM21", "DM15", "DM16"),    # thin-film flow through the gap
    "bruggeman": ("Br35", "P12", "D12", "WM21"),  # effective medium, Eq. 5-9
    "closed_form": ("WM21", "DM16"),         # Eq. 16
    "persson": ("P01", "YP08", "P20"),       # Persson theory of a_c(p), mean gap
    "scaling": ("WM21",),                    # finite-size scaling of a_c*
}


def contact_methods(model: str, method: str | None = None,
                    repulsion: str | None = None) -> tuple[str, ...]:
    """The :data:`METHODS` of a contact solve: the minimizer ``method`` (None: gfmd) of the
    elastic and adhesive models, or the bearing model; the adhesion; and FIRE, which the
    hard wall with adhesion (``repulsion="hard"``) runs (docs/physics.md 3.2)."""
    if model == "bearing":
        return ("bearing",)
    out = (method or "gfmd",)
    if model == "adhesive":
        out += ("adhesion",) + (("fire",) if repulsion == "hard" else ())
    return out


def threshold_methods(model: str, method: str | None = None,
                      repulsion: str | None = None) -> tuple[str, ...]:
    """The :data:`METHODS` of a threshold search: percolation, the contact solve's
    (:func:`contact_methods`) and, for the elastic model, the perimeter correction."""
    return ("percolation", *contact_methods(model, method, repulsion),
            *(("perimeter",) if model == "elastic" else ()))


#: The :data:`METHODS` of a leak curve: elastic contact, percolation and Reynolds flow.
LEAK_METHODS = ("gfmd", "percolation", "reynolds")


def references(methods: Collection[str] | None = None) -> list[Reference]:
    """The references of ``methods`` (names of :data:`METHODS`; None: all), the paper first,
    each once."""
    if methods is None:
        keys = list(REFERENCES)
    else:
        unknown = [m for m in methods if m not in METHODS]
        if unknown:
            from roughflow.errors import InputError

            raise InputError(f"unknown methods {unknown}; known: {', '.join(METHODS)}")
        keys = list(dict.fromkeys(k for m in methods for k in METHODS[m]))
    order = list(REFERENCES)
    return [REFERENCES[k] for k in sorted(keys, key=order.index)]


def keys_for(*methods: str) -> tuple[str, ...]:
    """The reference keys of ``methods`` (for the ``references`` attribute of a dataset)."""
    return tuple(r.key for r in references(methods))


def markdown(refs: list[Reference] | None = None, width: int = 95) -> str:
    """The list as docs/physics.md writes it (``- [KEY] text``, wrapped)."""
    refs = list(REFERENCES.values()) if refs is None else refs
    return "\n".join(textwrap.fill(f"- [{r.key}] {r.text()}", width=width,
                                   subsequent_indent="  ", break_on_hyphens=False,
                                   break_long_words=False) for r in refs)


def cff(version: str) -> str:
    """CITATION.cff of roughflow ``version``: the software, the paper as preferred citation,
    every reference."""
    import yaml

    paper = REFERENCES["WM21"].cff()
    doc = {
        "cff-version": "1.2.0",
        "message": "If you use roughflow, please cite the paper it reproduces and the "
                   "references of the methods you used (roughflow cite).",
        "type": "software",
        "title": "roughflow",
        "abstract": "Elastic contact, percolation and Reynolds flow for randomly rough "
                    "(an)isotropic surfaces.",
        "version": version,
        "license": "MIT",
        "authors": [{"name": "The roughflow developers"}],
        "preferred-citation": paper,
        "references": [r.cff() for r in REFERENCES.values()],
    }
    return ("# Generated by `roughflow cite --format cff` from roughflow/citation.py.\n"
            + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=95))
