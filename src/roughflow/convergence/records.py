"""The study's files: their names, and the JSON-lines records appended and read one per
line.

Each study writes two files of one stem under ``--out``: the record log (``.jsonl``), to
which records are appended as they are measured (an interrupted run keeps what it finished,
and a rerun into the same file computes only what is missing), and, when a run completes,
the whole log as one netCDF dataset (``.nc``, :mod:`.dataset`): the job's output, which the
reports read.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from roughflow.errors import InputError

#: the record log (JSON lines, appended and resumed from) and the dataset written from it
#: at the end of a run (netCDF, what the reports read): one stem, these suffixes
LOG_SUFFIX = ".jsonl"
DATASET_SUFFIX = ".nc"
#: the resolution study's stem (gamma 1; other gammas append ``_g<gamma>``)
RESOLUTION_STEM = "convergence_resolution"
#: the tolerance study's stem
TOLERANCE_STEM = "convergence_tol"
#: every resolution dataset (one per gamma), for the anisotropic report
RESOLUTION_GLOB = f"{RESOLUTION_STEM}*{DATASET_SUFFIX}"
#: the isotropic report: STEM.md, STEM.csv and its two plots (resolution, tolerances)
REPORT_STEM = "convergence"
REPORT_PLOTS = ("convergence_resolution.png", "convergence_tolerances.png")
#: the anisotropic report: STEM.md, STEM.csv and STEM.png
ANISOTROPIC_STEM = "convergence_anisotropic"


def report_files() -> list[str]:
    """The names of every file the reports write."""
    return [f"{REPORT_STEM}.md", f"{REPORT_STEM}.csv", *REPORT_PLOTS,
            *(f"{ANISOTROPIC_STEM}{suffix}" for suffix in (".md", ".csv", ".png"))]


def _suffix(dataset: bool) -> str:
    return DATASET_SUFFIX if dataset else LOG_SUFFIX


def resolution_file(out: str | os.PathLike, gamma: float, *, dataset: bool = False) -> Path:
    """The resolution study's record log for one gamma (the isotropic name is kept), or with
    ``dataset`` the netCDF dataset written from it."""
    stem = RESOLUTION_STEM if gamma == 1.0 else f"{RESOLUTION_STEM}_g{gamma:g}"
    return Path(out) / (stem + _suffix(dataset))


def tolerance_file(out: str | os.PathLike, *, dataset: bool = False) -> Path:
    """The tolerance study's record log, or with ``dataset`` the dataset written from it."""
    return Path(out) / (TOLERANCE_STEM + _suffix(dataset))


def dataset_file(log: Path) -> Path:
    """The dataset written from the record log ``log``: the same name, ``.nc``."""
    return log.with_suffix(DATASET_SUFFIX)


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
