"""``roughflow cite``: the references behind roughflow's methods, or behind given results."""

from __future__ import annotations

import argparse

from ._common import add_input

FORMATS = ("text", "bibtex", "markdown", "cff")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "cite", help="print the references to cite (all, per method, or of result files)",
        description="Print the publications behind roughflow's methods (roughflow/citation.py, "
                    "the list of docs/physics.md): all of them, those of --method, or those "
                    "that the given result files record in their 'references' attribute "
                    "(every file roughflow writes lists the methods it used). The paper "
                    "roughflow reproduces comes first.")
    add_input(p, "files", kinds=None, what="result file", nargs="*", metavar="RESULT.nc",
              help="netCDF files written by roughflow (optional)")
    p.add_argument("--method", action="append", default=None, metavar="NAME",
                   help="only the references of this method (repeatable; not with result "
                        "files): " +
                        ", ".join(_methods()))
    p.add_argument("--format", choices=FORMATS, default="text",
                   help="text (default), bibtex, markdown (as in docs/physics.md) or cff "
                        "(CITATION.cff of this version; without files or --method)")
    p.set_defaults(func=run)


def _methods() -> list[str]:
    from roughflow.citation import METHODS

    return list(METHODS)


def run(args: argparse.Namespace) -> None:
    from roughflow import __version__
    from roughflow.citation import REFERENCES, cff, markdown, references
    from roughflow.errors import InputError
    from roughflow.provenance import input_references

    _check_selection(args)
    if args.format == "cff":
        print(cff(__version__), end="")
        return
    refs = references(args.method)
    if args.files:
        keys = set(input_references(*args.data["files"]))
        if not keys:
            raise InputError("the files record no references (not written by roughflow, or "
                             "by a version that did not record them)")
        unknown = sorted(keys - set(REFERENCES))
        if unknown:
            raise InputError(f"the files cite unknown reference keys {unknown}")
        refs = [r for r in refs if r.key in keys]
    if args.format == "markdown":
        print(markdown(refs))
    elif args.format == "bibtex":
        print("\n\n".join(r.bibtex() for r in refs))
    else:
        print("\n".join(f"[{r.key}] {r.text()}" for r in refs))


def _check_selection(args: argparse.Namespace) -> None:
    """Refuse selections that would be ignored, or select nothing: result files and
    --method are alternatives (a file that used other methods would print nothing), and
    the CFF file is roughflow's own citation, of neither."""
    from roughflow.errors import InputError

    method = " ".join(f"--method {m}" for m in args.method or ())
    if args.format == "cff" and (args.files or method):
        got = ", ".join([*args.files, *([method] if method else [])])
        raise InputError("--format cff prints roughflow's own CITATION.cff, which takes "
                         f"neither result files nor --method (got {got})")
    if args.files and method:
        raise InputError(f"{method} and result files are alternatives: give the files (their "
                         "references) or --method (a method's), not both")
