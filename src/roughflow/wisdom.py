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
that is ``~/.cache/roughflow/fftw``), one JSON file per machine (:func:`machine_key`: CPU,
FFTW build) and planner effort, because wisdom holds only for the machine that measured it,
and FFTW takes wisdom of a higher effort in place of planning at a lower one (one
``FFTW_PATIENT`` run would otherwise change the algorithms of every later ``FFTW_MEASURE``
run). Within a process, each effort plans from its own wisdom too. ``ROUGHFLOW_FFTW_WISDOM=off``
keeps it in the process. The files are readable, and the lock files usable, by whoever may
read the directory, so a group can share one. The file can only ever cost speed: one that
cannot be read is replaced, and a directory that cannot be written is reported once: the
wisdom it holds is still read, but what a run plans is not saved there. A process waits
:data:`LOCK_WAIT_S` at most for another's lock (a stopped holder, perhaps another user's
job, held every later process for good), then plans without it and saves nothing.
"""

from __future__ import annotations

import contextlib
import glob
import hashlib
import json
import logging
import os
import platform
import re
import tempfile
import threading
from collections.abc import Iterator
from functools import lru_cache
from pathlib import Path

from roughflow.errors import InputError
from roughflow.files import (
    flock_within,
    open_lock_file,
    publish,
    remove_stale,
    sticky_owner,
    user_cache_dir,
    user_name,
)

log = logging.getLogger(__name__)

#: The environment variable naming the wisdom directory ("off": no file).
ENV = "ROUGHFLOW_FFTW_WISDOM"

#: How long (s) a process waits for another's lock on the file before it plans without it
#: (reading the file, saving nothing): the holder times at most one pair of plans, 1-18 s
#: with FFTW_MEASURE here, but one stopped or hung (SIGSTOP, a suspended job, perhaps another
#: user's that this one cannot end) held every later process of the machine for good.
LOCK_WAIT_S = 300.0

#: pyFFTW's wisdom is a triple (double, single, long double); the file keeps the names.
_PRECISIONS = ("double", "single", "long_double")

_reported: set[str] = set()  # problems already logged, so a sweep's log says each once

# FFTW's planner and its wisdom are one per process: threads plan in turn
_PROCESS_LOCK = threading.Lock()
# the wisdom this process holds per planner effort (shared() swaps it into FFTW)
_held: dict[str, tuple[bytes, ...]] = {}

# pyFFTW's export: a header line, one line per entry, ")". An entry's two flag fields are
# 20-bit and its time limit 9-bit: a wider value makes FFTW abort the process on an
# assertion while it plans (FFTW issue 214), so such a file is refused before FFTW sees it.
_HEADER = re.compile(r"\(fftw-\S+ fftw[fl]?_wisdom( #x[0-9a-f]{1,8}){4}")
_ENTRY = re.compile(r"  \([A-Za-z0-9_]+ \d+ #x[0-9a-f]{1,5} #x[0-9a-f]{1,5} #x([0-9a-f]{1,3})"
                    r"( #x[0-9a-f]{1,8}){4}\)")


def directory() -> Path | None:
    """The wisdom directory from :data:`ENV` (None: ``off``, or no directory to default to)."""
    raw = os.environ.get(ENV)
    if raw is None:
        default = user_cache_dir("fftw")
        if default is None:
            _report("no home directory to keep the file in", "HOME is not set",
                    f"the wisdom stays in the process (set {ENV} to share it)")
        return default
    if raw.strip().lower() == "off":
        return None
    if not raw.strip():
        raise InputError(f"{ENV} must be a directory or 'off', got {raw!r}")
    try:
        d = Path(raw).expanduser()
    except RuntimeError as err:  # ~user of no user, or ~ without a home directory
        raise InputError(f"{ENV}={raw!r}: {str(err).rstrip('.')}; give the directory "
                         f"without ~") from None
    if str(d).startswith("~"):
        raise InputError(f"{ENV}={raw!r}: there is no home directory to expand ~ to; give the "
                         f"directory without ~")
    return d


def _cpu_description() -> str:
    """What names the CPU in /proc/cpuinfo (its first processor): the model name on x86,
    implementer and part on ARM, the ``cpu`` line on POWER, and the feature flags, which
    tell apart CPUs that a virtual machine names alike."""
    keys = ("model name", "cpu", "CPU implementer", "CPU architecture", "CPU variant",
            "CPU part", "flags", "Features")
    found: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if not line.strip():
                    if found:
                        break
                    continue
                key, _, value = line.partition(":")
                if key.strip() in keys:
                    found.setdefault(key.strip(), value.strip())
    except OSError:
        pass
    if not found:
        return platform.processor() or "unknown"
    return "|".join(f"{k}={found[k]}" for k in keys if k in found)


@lru_cache(maxsize=1)
def machine_key() -> str:
    """A short hash of what FFTW's timings and its wisdom depend on: OS, architecture, CPU
    (:func:`_cpu_description`), pyFFTW and the build of the FFTW it runs (the header of
    each precision's wisdom: another build rejects the file, and would overwrite it)."""
    import pyfftw

    headers = [w.decode("ascii", "replace").split("\n", 1)[0] for w in pyfftw.export_wisdom()]
    text = "|".join((platform.system(), platform.machine(), _cpu_description(),
                     pyfftw.__version__, *headers))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def path(effort: str) -> Path | None:
    """This machine's wisdom file for planner ``effort`` (None: :data:`ENV` is ``off``)."""
    d = directory()
    name = effort.removeprefix("FFTW_").lower()
    return None if d is None else d / f"wisdom-{machine_key()}-{name}.json"


def _report(problem: str, err: Exception | str, consequence: str = "planning goes on "
            "without the file") -> None:
    if problem not in _reported:
        _reported.add(problem)
        log.warning("FFTW wisdom: %s (%s); %s", problem, err, consequence)


def entries(wisdom: tuple[bytes, ...]) -> tuple[frozenset[bytes], ...]:
    """Each precision's wisdom as a set of lines: FFTW exports what it holds in an order
    that depends on how it came by it (read, imported again, planned)."""
    return tuple(frozenset(w.splitlines()) for w in wisdom)


def _valid(text: str) -> bool:
    """Whether ``text`` is one precision's wisdom as FFTW exports it, every field in range
    ("" for a precision the pyFFTW build lacks, e.g. long double)."""
    if text == "":
        return True
    lines = text.splitlines()
    if len(lines) < 2 or not _HEADER.fullmatch(lines[0]) or lines[-1] != ")":
        return False
    for line in lines[1:-1]:
        m = _ENTRY.fullmatch(line)
        if m is None or int(m[1], 16) >= 1 << 9:
            return False
    return True


def _load(file: Path) -> tuple[bytes, ...] | None:
    """Import ``file``'s wisdom; returns it (None: no usable file)."""
    import pyfftw

    try:
        raw = file.read_bytes()
    except (FileNotFoundError, NotADirectoryError):  # nothing saved (yet)
        return None
    try:  # UnicodeDecodeError (a stray non-ASCII byte) is a ValueError too
        data = json.loads(raw.decode("ascii"))
        wisdom = tuple(data[k].encode("ascii") for k in _PRECISIONS)
        bad = [k for k in _PRECISIONS if not _valid(data[k])]
        if bad:
            raise ValueError(f"its {bad[0]} wisdom is not FFTW's format or has a field out "
                             f"of range")
    except (ValueError, KeyError, TypeError, AttributeError) as err:
        _report(f"{file} is not a wisdom file and will be replaced", err)
        return None
    pyfftw.import_wisdom(wisdom)  # a part FFTW rejects (another FFTW build) is left out
    return wisdom


def _save(file: Path, wisdom: tuple[bytes, ...]) -> None:
    # written beside the file and renamed over it: a reader never sees half a file
    data = {k: w.decode("ascii") for k, w in zip(_PRECISIONS, wisdom, strict=True)}
    # a job killed while writing (SIGKILL, out of memory) left its temporary file: removed
    # here, under the lock, once it is old enough not to be another job's in progress
    remove_stale(file.parent.glob(f"{glob.escape(file.name)}*.tmp"))
    fd, tmp = tempfile.mkstemp(prefix=file.name, suffix=".tmp", dir=file.parent)
    try:
        with os.fdopen(fd, "w", encoding="ascii") as f:
            json.dump(data, f, indent=0)
        publish(tmp, file)  # readable by those who may read the directory
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _open_lock(file: Path) -> int | None:
    """A descriptor of ``file``'s lock file, made readable and writable by those the umask
    allows. Another user's lock file opens read-only: flock needs no write permission."""
    lock = file.with_name(file.name + ".lock")
    not_saved = "its wisdom is read if there is any, but what this run plans is not saved"
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        # a folder that cannot be written may still hold wisdom, which shared() reads
        _report(f"cannot write to {file.parent}", err, not_saved)
        return None
    try:
        return open_lock_file(lock)
    except OSError as err:
        _report(f"cannot open the lock file {lock}", err, not_saved)
        return None


@contextlib.contextmanager
def _locked(file: Path) -> Iterator[bool]:
    """Hold an exclusive lock on ``file``'s lock file; yields False where there is no lock
    file, or another process held it for :data:`LOCK_WAIT_S` (nothing is saved then; once
    that happened, this process tries the lock once instead of waiting again)."""
    fd = _open_lock(file)
    if fd is None:
        yield False
        return
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock, so two processes may time the same shape
        fcntl = None
    lock = file.with_name(file.name + ".lock")
    try:
        taken = True
        try:
            taken = fcntl is None or flock_within(fd, lock, LOCK_WAIT_S)
        except OSError as err:  # some network file systems (Lustre without flock)
            _report(f"cannot lock {file.name}.lock", err,
                    "planning goes on unlocked: jobs may time the same shape, and a shape "
                    "another job saved at the same moment can be lost from the file (it is "
                    "timed again later, and its plan, so results, may then differ in the "
                    "last bits)")
        if not taken:
            _report(f"another process holds {lock}", f"for {LOCK_WAIT_S:g} s: stopped, or "
                    "timing a shape at a high planner effort",
                    "this process reads the file but plans without waiting for the lock and "
                    "saves nothing: it may time a shape that process times, and its results "
                    "may then differ from that process's in the last bits")
        yield taken
    finally:
        os.close(fd)  # releases the lock


@contextlib.contextmanager
def shared(effort: str) -> Iterator[None]:
    """Around the making of FFTW plans with planner ``effort``: FFTW holds the wisdom this
    process gathered under ``effort`` and nothing else, the machine's file for ``effort`` is
    read first, and what the planning added is merged into the file after, all under the
    file's lock, so a shape is timed by one process only. ``FFTW_ESTIMATE`` plans from no
    wisdom at all (they would take measured algorithms from it) and keep none."""
    import pyfftw

    with _PROCESS_LOCK:
        pyfftw.forget_wisdom()
        if effort == "FFTW_ESTIMATE":
            yield
            return
        if effort in _held:
            pyfftw.import_wisdom(_held[effort])
        file = path(effort)
        with contextlib.nullcontext(False) if file is None else _locked(file) as usable:
            saved = None
            try:  # a directory this process cannot write may still hold wisdom to read
                saved = None if file is None else _load(file)
            except OSError as err:
                _report(f"cannot read {file}", err)
            try:
                yield
            finally:
                _held[effort] = pyfftw.export_wisdom()
            # what this process holds and the file lacks: planned now, or earlier when a
            # save was interrupted or failed (it would never reach the file otherwise)
            if usable and _lacks(saved, _held[effort]):
                try:
                    _load(file)  # what others saved meanwhile (a file system without locks)
                    _save(file, pyfftw.export_wisdom())
                except OSError as err:
                    owner = sticky_owner(file)
                    _report(f"cannot write {file}", err, "planning goes on without the file" + (
                        f"; it belongs to {user_name(owner)} in a folder with the sticky bit, "
                        "where only its owner may replace it: a group shares wisdom through "
                        "a setgid folder (chmod 2775) instead" if owner is not None else ""))


def _lacks(saved: tuple[bytes, ...] | None, held: tuple[bytes, ...]) -> bool:
    """Whether ``held`` has entries the file's wisdom ``saved`` (None: none) lacks."""
    in_file = entries(saved) if saved is not None else (frozenset(),) * len(held)
    return any(h - f for h, f in zip(entries(held), in_file, strict=True))
