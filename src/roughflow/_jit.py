"""numba's ``njit`` for roughflow's kernels, with their compile cache kept per version of the
package source.

numba checks a cached kernel against its own source file only. A kernel that calls a kernel
of another module (the union-find of ``percolation.sweep`` in ``percolation.spanning`` and
``flow.bound``) or reads a constant of another module (numba freezes globals into the
machine code) kept its old machine code after that other file changed: with an editable
install, ``git pull`` left results computed by old code under the new commit's name. The
cache therefore lives in a folder named after a hash of every source file of the package
(:func:`cache_dir`): a changed file compiles the kernels afresh, once (a threshold search's
kernels take about 6 s). The versions live in ``$NUMBA_CACHE_DIR/roughflow``, else
``$XDG_CACHE_HOME/roughflow/numba``, else ``~/.cache/roughflow/numba``; where that cannot be
written, in the temporary folder; where neither can, the kernels are compiled in every
process (never cached beside their source files, numba's fallback, which is per file).
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numba

from roughflow.files import user_cache_dir

#: Versions of the compiled kernels kept ...
KEEP = 4
#: ... and the time (s) a version must have gone unused before it is removed: a long job
#: of an older checkout may still load from it.
PRUNE_AFTER_S = 86400.0
_PACKAGE = Path(__file__).resolve().parent


def source_key(package: Path = _PACKAGE) -> str:
    """Hash of the relative path and content of every ``.py`` file under ``package`` (real
    files only: an editor's lock file is a dangling link named ``.#name.py``)."""
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        if path.name.startswith(".") or not path.is_file():
            continue
        digest.update(path.relative_to(package).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def _parents() -> list[Path]:
    """Where the versions may live, the preferred place first."""
    given = os.environ.get("NUMBA_CACHE_DIR")
    first = Path(given).expanduser() / "roughflow" if given else user_cache_dir("numba")
    spare = Path(tempfile.gettempdir()) / f"roughflow-numba-{os.getuid()}"
    return [p for p in (first, spare) if p is not None]


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder):
            pass
    except OSError:
        return False
    return True


def _prune(parent: Path, here: Path) -> None:
    """Remove versions beyond the :data:`KEEP` most recently used ones that have gone
    unused for :data:`PRUNE_AFTER_S`."""
    try:
        versions = sorted((p for p in parent.iterdir() if p.is_dir()),
                          key=lambda p: p.stat().st_mtime, reverse=True)
        old = time.time() - PRUNE_AFTER_S
        for p in versions[KEEP:]:
            if p != here and p.stat().st_mtime < old:
                shutil.rmtree(p, ignore_errors=True)
    except OSError:  # another process pruned at the same time
        pass


@functools.cache
def cache_dir() -> Path | None:
    """This package version's kernel cache (None: no writable place, no cache)."""
    try:
        key = source_key()
    except OSError:
        return None
    for parent in _parents():
        here = parent / key
        if _writable(here):
            os.utime(here)  # most recently used
            _prune(parent, here)
            return here
    return None


def njit(**options) -> Callable[[Callable], Callable]:
    """``numba.njit(**options)``; with ``cache=True`` the kernel's cache is
    :func:`cache_dir` (numba fixes a kernel's cache path when it is decorated, so the
    setting is made for the decoration only and the caller's own numba setting stays)."""
    if not options.get("cache"):
        return numba.njit(**options)
    where = cache_dir()
    if where is None:
        return numba.njit(**{**options, "cache": False})
    decorate = numba.njit(**options)

    def apply(func: Callable) -> Callable:
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = str(where)
        try:
            return decorate(func)
        finally:
            numba.config.CACHE_DIR = saved

    return apply
