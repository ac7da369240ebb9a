"""The study's files: their names, and the JSON-lines records appended and read one per
line.

Records are appended as they are measured (an interrupted run keeps what it finished, and a
rerun into the same file computes only what is missing).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from roughflow.errors import InputError

#: the tolerance study's records
TOLERANCE_FILE = "convergence_tol.jsonl"
#: every resolution file (one per gamma), for the anisotropic report
RESOLUTION_GLOB = "convergence_resolution*.jsonl"
#: the isotropic report: STEM.md, STEM.csv and its two plots (resolution, tolerances)
REPORT_STEM = "convergence"
REPORT_PLOTS = ("convergence_resolution.png", "convergence_tolerances.png")
#: the anisotropic report: STEM.md, STEM.csv and STEM.png
ANISOTROPIC_STEM = "convergence_anisotropic"


def report_files() -> list[str]:
    """The names of every file the reports write."""
    return [f"{REPORT_STEM}.md", f"{REPORT_STEM}.csv", *REPORT_PLOTS,
            *(f"{ANISOTROPIC_STEM}{suffix}" for suffix in (".md", ".csv", ".png"))]


def resolution_file(out: str | os.PathLike, gamma: float) -> Path:
    """JSON-lines file of the resolution study for one gamma (the isotropic name is kept)."""
    name = ("convergence_resolution.jsonl" if gamma == 1.0
            else f"convergence_resolution_g{gamma:g}.jsonl")
    return Path(out) / name


def tolerance_file(out: str | os.PathLike) -> Path:
    """JSON-lines file of the tolerance study."""
    return Path(out) / TOLERANCE_FILE


def append_record(path: Path, rec: dict) -> None:
    """Append ``rec`` as one JSON line to ``path`` (folders created)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as f:
        f.write(json.dumps(rec) + "\n")


def load_records(path: Path) -> list[dict]:
    """The records of ``path`` ([] when it does not exist); :class:`InputError` naming the
    line that is no record (an append cut short by a kill or a full disk)."""
    if not path.exists():
        return []
    records = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except json.JSONDecodeError as exc:
            raise InputError(f"{path}:{number} is not a complete record ({exc.msg}): a run "
                             "cut short while writing? Remove that line (the run resumes "
                             "without it) or the file") from None
        if not isinstance(rec, dict) or "kind" not in rec:
            raise InputError(f"{path}:{number} is not a record of the accuracy study")
        records.append(rec)
    return records
