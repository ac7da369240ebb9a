"""What the reports share: markdown tables, the notes on extrapolated references, cell and
plot labels, and writing a report's files together."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from roughflow import accuracy

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: note under every table whose reference is the first-order Richardson extrapolation
EXTRAP_NOTE = ("Rows marked (extrapolation) are the two grids the reference is extrapolated "
               "from: their errors are -r/(r-1) and -1/(r-1) times the difference of the two "
               "grids (r = spacing ratio), fixed by construction, not measured.")

#: the same for the plots: their points at the reference's own grids are labelled "ref"
PLOT_EXTRAP_NOTE = "ref: a grid of the reference (its error is no measurement)"


def md_table(header: list[str], rows: list[list]) -> str:
    """A markdown table; floats with 4 significant digits."""
    def fmt(v: object) -> str:
        if isinstance(v, float):
            return f"{v:.4g}"
        return str(v)
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(v) for v in r) + " |" for r in rows]
    return "\n".join(lines)


def plot_label(p: int, fine: Sequence[int], variant: str) -> str:
    """Label of a plotted point: its points per lambda_s, "ref" on the reference's grids."""
    return f"{p} ref" if p in fine and variant != "richardson" else str(p)


def a_star_references(thr: list[dict], seeds: Sequence[int], fine: tuple[int, int]
                      ) -> dict[tuple[int, int], float]:
    """The reference a_c* per (seed, axis): the first-order Richardson extrapolation of the
    threshold records ``thr`` at the two finest resolutions ``fine``."""
    f0, f1 = fine
    refs = {}
    for s in seeds:
        rr = {q["ppl"]: q for q in thr if q["seed"] == s}
        for ax in (0, 1):
            refs[(s, ax)] = accuracy.richardson(rr[f0][f"a_star_{ax}"],
                                                rr[f1][f"a_star_{ax}"], ratio=f1 / f0)
    return refs


def ppl_cell(p: int, fine: Sequence[int]) -> int | str:
    """ppl cell of a table: the reference's own grids are marked (their error is no
    measurement)."""
    return f"{p} (extrapolation)" if p in fine else p


@dataclass(frozen=True)
class ReportFiles:
    """A written report: its markdown text and the files (tables, CSV, plots)."""

    markdown: str
    paths: tuple[Path, ...]


@dataclass(frozen=True)
class ReportDraft:
    """A report ready to be written: ``stem``.md, ``stem``.csv and the figures (file name ->
    Figure, 120 dpi)."""

    stem: str
    markdown: str
    csv: str
    figures: dict[str, Figure]

    @classmethod
    def of(cls, stem: str, md: list[str], csv_rows: list[str],
           figures: dict[str, Figure]) -> ReportDraft:
        return cls(stem, "\n".join(md), "\n".join(csv_rows) + "\n", figures)

    def file_names(self) -> list[str]:
        return [*self.figures, f"{self.stem}.md", f"{self.stem}.csv"]


def publish_reports(out: str | os.PathLike, drafts: Sequence[ReportDraft]) -> list[ReportFiles]:
    """Every file of ``drafts`` under ``out``, published together
    (:func:`roughflow.io.write_together`: all or none, so that no report is left beside
    another's stale files after a failure)."""
    from roughflow.io import figure_writer, write_together

    outdir = Path(out)
    writers = []
    for draft in drafts:
        for name, fig in draft.figures.items():
            fig.tight_layout()
            writers.append(figure_writer(fig, outdir / name, dpi=120))
        writers += [(outdir / f"{draft.stem}.md",
                     lambda tmp, text=draft.markdown: Path(tmp).write_text(text)),
                    (outdir / f"{draft.stem}.csv",
                     lambda tmp, text=draft.csv: Path(tmp).write_text(text))]
    paths = write_together(writers)
    out_files, start = [], 0
    for draft in drafts:
        n = len(draft.file_names())
        out_files.append(ReportFiles(draft.markdown, tuple(paths[start:start + n])))
        start += n
    return out_files
