"""FFTW wisdom kept on disk: each FFT shape is timed once per machine, not once per process.

``FFTW_MEASURE`` (:mod:`roughflow.fft`'s default planner effort) picks each transform's
algorithm by timing candidates. Here its transforms take 0.4-0.7x the time of
``FFTW_ESTIMATE``'s heuristic choice from 1024^2 on, but timing costs 1 s (1024^2) to 18 s
(2048 x 16384) per shape, and as the choice depends on the timings, two processes can pick
different algorithms and so round differently. The wisdom file removes both costs: the first
process that plans a shape times it while holding a lock on the file and saves its choice;
every later process on the machine, such as the other jobs of a sweep, reads that choice
instead of timing. Runs on one machine are then bit-identical, as they are with
``FFTW_ESTIMATE``.

Where: the directory ``ROUGHFLOW_FFTW_WISDOM`` (default ``$XDG_CACHE_HOME/roughflow/fftw``,
that is ``~/.cache/roughflow/fftw``), one JSON file per CPU model and pyFFTW version, because
wisdom holds only for the machine that measured it; ``ROUGHFLOW_FFTW_WISDOM=off`` keeps it
in the process. The file can only ever cost speed: one that cannot be read is replaced, and
a directory that cannot be written is reported once: the wisdom it holds is still read, but
what a run plans is not saved there.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import platform
import tempfile
from collections.abc import Iterator
from functools import lru_cache
from pathlib import Path

from roughflow.errors import InputError

log = logging.getLogger(__name__)

#: The environment variable naming the wisdom directory ("off": no file).
ENV = "ROUGHFLOW_FFTW_WISDOM"

#: pyFFTW's wisdom is a triple (double, single, long double); the file keeps the names.
_PRECISIONS = ("double", "single", "long_double")

_reported: set[str] = set()  # problems already logged, so a sweep's log says each once


def directory() -> Path | None:
    """The wisdom directory from :data:`ENV` (None: ``off``)."""
    raw = os.environ.get(ENV)
    if raw is None:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        return Path(base) / "roughflow" / "fftw"
    if raw.strip().lower() == "off":
        return None
    if not raw.strip():
        raise InputError(f"{ENV} must be a directory or 'off', got {raw!r}")
    return Path(raw).expanduser()


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


@lru_cache(maxsize=1)
def machine_key() -> str:
    """A short hash of what FFTW's timings depend on: OS, architecture, CPU model, pyFFTW
    (which ships its FFTW)."""
    import pyfftw

    text = "|".join((platform.system(), platform.machine(), _cpu_model(), pyfftw.__version__))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def path() -> Path | None:
    """This machine's wisdom file (None: :data:`ENV` is ``off``)."""
    d = directory()
    return None if d is None else d / f"wisdom-{machine_key()}.json"


def _report(problem: str, err: Exception, consequence: str = "planning goes on without the "
            "file") -> None:
    if problem not in _reported:
        _reported.add(problem)
        log.warning("FFTW wisdom: %s (%s); %s", problem, err, consequence)


def _load(file: Path) -> None:
    import pyfftw

    try:
        raw = file.read_bytes()
    except (FileNotFoundError, NotADirectoryError):  # nothing saved (yet)
        return
    try:  # UnicodeDecodeError (a stray non-ASCII byte) is a ValueError too
        data = json.loads(raw.decode("ascii"))
        wisdom = tuple(data[k].encode("ascii") for k in _PRECISIONS)
    except (ValueError, KeyError, TypeError, AttributeError) as err:
        _report(f"{file} is not a wisdom file and will be replaced", err)
        return
    pyfftw.import_wisdom(wisdom)  # a part FFTW rejects (another FFTW build) is left out


def _save(file: Path, wisdom: tuple[bytes, ...]) -> None:
    # written beside the file and renamed over it: a reader never sees half a file
    data = {k: w.decode("ascii") for k, w in zip(_PRECISIONS, wisdom, strict=True)}
    fd, tmp = tempfile.mkstemp(prefix=file.name, suffix=".tmp", dir=file.parent)
    try:
        with os.fdopen(fd, "w", encoding="ascii") as f:
            json.dump(data, f, indent=0)
        os.replace(tmp, file)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def _locked(file: Path) -> Iterator[bool]:
    """Hold an exclusive lock on ``file``'s lock file; yields False where none can be had."""
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        handle = open(file.with_name(file.name + ".lock"), "a")  # noqa: SIM115 - closed below
    except OSError as err:
        # a folder that cannot be written may still hold wisdom, which shared() reads
        _report(f"cannot write to {file.parent}", err,
                "its wisdom is read if there is any, but what this run plans is not saved")
        handle = None
    if handle is None:
        yield False
        return
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock, so two processes may time the same shape
        fcntl = None
    with handle:
        try:
            if fcntl is not None:
                fcntl.flock(handle, fcntl.LOCK_EX)
        except OSError as err:  # some network file systems: go on unlocked
            _report(f"cannot lock {handle.name}", err)
        yield True  # closing the handle releases the lock


@contextlib.contextmanager
def shared(effort: str) -> Iterator[None]:
    """Around the making of FFTW plans with planner ``effort``: the machine's wisdom is read
    first and what the planning added is saved after, all under the file's lock, so a shape
    is timed by one process only. ``FFTW_ESTIMATE`` plans neither read nor write it (they
    would take measured algorithms from read wisdom)."""
    file = None if effort == "FFTW_ESTIMATE" else path()
    if file is None:
        yield
        return
    import pyfftw

    with _locked(file) as usable:
        try:  # a directory this process cannot write may still hold wisdom to read
            _load(file)
        except OSError as err:
            _report(f"cannot read {file}", err)
        if not usable:
            yield
            return
        before = pyfftw.export_wisdom()
        yield
        after = pyfftw.export_wisdom()
        if after != before:
            try:
                _save(file, after)
            except OSError as err:
                _report(f"cannot write {file}", err)
