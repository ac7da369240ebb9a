"""The study's files: their names, and the JSON-lines records appended and read one per
line.

Each study writes two files of one stem under ``--out``: the record log (``.jsonl``), to
which records are appended as they are measured (an interrupted run keeps what it finished,
and a rerun into the same file computes only what is missing), and, when a run completes,
the whole log as one netCDF dataset (``.nc``, :mod:`.dataset`): the job's output, which the
reports read. A run writes its log through :class:`RecordLog`, one run at a time.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path

from roughflow.errors import InputError

log = logging.getLogger(__name__)

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


class RecordLog:
    """The record log ``path`` held open by one run from before it reads the log until it
    ends (a context manager).

    Its records go to the file this run opened, not to whatever ``path`` names later: a run
    that lives on after its job was ended (a killed shell wrapper leaves its Python child
    running) and whose log the rerun removed appends to the removed file, not into the
    rerun's log, and :meth:`require_current` keeps it from writing a dataset. An exclusive
    ``flock`` refuses a second run on the same log while the first holds it (where the file
    system has no flock, the run goes on unlocked, with a warning).
    """

    def __init__(self, path: Path):
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._file = path.open("a")
        try:
            import fcntl
        except ImportError:  # not POSIX: no lock
            return
        try:
            fcntl.flock(self._file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._file.close()
            raise InputError(
                f"{path} is being written by another run of the study (one still running, or "
                "one whose job was ended while its process lives on): wait for it or stop "
                "it, or give another --out") from None
        except OSError as err:  # some network file systems (Lustre without flock)
            log.warning("cannot lock %s (%s): the run goes on unlocked, and a second run on "
                        "the same log would not be refused", path, err)

    def append(self, rec: dict) -> None:
        """Append ``rec`` as one JSON line, flushed (a run killed later keeps it)."""
        self._file.write(json.dumps(rec) + "\n")
        self._file.flush()

    def require_current(self) -> None:
        """:class:`InputError` where ``path`` no longer names the file this run appended
        to: the log was removed or replaced under the run (by a rerun), whose records and
        dataset are not this run's to write."""
        mine = os.fstat(self._file.fileno())
        try:
            now = os.stat(self.path)
        except FileNotFoundError:
            now = None
        if now is None or (now.st_dev, now.st_ino) != (mine.st_dev, mine.st_ino):
            raise InputError(
                f"{self.path} was removed or replaced while this run wrote it (a rerun of "
                "the job started meanwhile?): this run's records went to the old file, and "
                "it writes no dataset")

    def close(self) -> None:
        self._file.close()  # releases the lock

    def __enter__(self) -> RecordLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


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
