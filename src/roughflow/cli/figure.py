"""``roughflow figure``: draw a study's figure (PNG and PDF) from its dataset."""

from __future__ import annotations

import argparse

from roughflow.defaults import STUDIES

from ._common import add_input, add_output


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "figure", help="draw a study's figure (PNG + PDF) from its aggregated dataset",
        description="Draw the paper figure of a study from its aggregated dataset; writes "
                    "the PNG given by -o and a PDF next to it (--caption: and prints the "
                    "caption).")
    p.add_argument("study", choices=STUDIES, help="study name")
    add_input(p, "dataset", kinds=None, what="study dataset", metavar="DATASET.nc",
              help="aggregated study dataset (roughflow aggregate; channels: roughflow scene "
                   "channels)")
    add_input(p, "--fit", kinds="fit", what="fit file", default=None, metavar="FIT.nc",
              help="fit results (threshold_vs_size; roughflow fit)")
    p.add_argument("--caption", action="store_true", help="print the caption to stdout")
    add_output(p, suffixes=(".png",), metavar="FIGURE.png",
               help="PNG file to write; the PDF is written next to it (same name, .pdf)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> None:
    from roughflow.figures import make_figure

    caption = make_figure(args.study, args.data["dataset"], args.output, fit=args.data["fit"],
                          source=f"study dataset {args.dataset!r}")
    if args.caption:
        print(caption)
