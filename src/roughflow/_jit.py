"""numba's ``njit`` for roughflow's kernels, with their compile cache kept per version of the
package source.

numba checks a cached kernel against its own source file only. A kernel that calls a kernel
of another module (the union-find of ``percolation.sweep`` in ``percolation.spanning`` and
``flow.bound``) or reads a constant of another module (numba freezes globals into the
machine code) kept its old machine code after that other file changed: with an editable
install, ``git pull`` left results computed by old code under the new commit's name. The
cache therefore lives in a directory named after a hash of every source file of the package
(:func:`cache_dir`): a changed file compiles the kernels afresh, once (a threshold search's
kernels take about 6 s). The directory's parent is ``$NUMBA_CACHE_DIR``, else
``$XDG_CACHE_HOME/roughflow/numba``, else ``~/.cache/roughflow/numba``, else one in the
temporary directory; only the :data:`KEEP` most recently used versions are kept there.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

import numba

#: Versions of the compiled kernels kept in the cache's parent directory.
KEEP = 4
_PACKAGE = Path(__file__).resolve().parent
_PREFIX = "roughflow-"


def source_key(package: Path = _PACKAGE) -> str:
    """Hash of the relative path and content of every ``.py`` file under ``package``."""
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def _parent() -> Path:
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:
        return Path(given).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg:
        return Path(xdg) / "roughflow" / "numba"
    home = os.path.expanduser("~")
    if os.path.isabs(home):
        return Path(home) / ".cache" / "roughflow" / "numba"
    return Path(tempfile.gettempdir()) / f"roughflow-numba-{os.getuid()}"


@functools.cache
def cache_dir() -> Path:
    """This package version's kernel cache; older versions beyond :data:`KEEP` removed."""
    parent = _parent()
    here = parent / f"{_PREFIX}{source_key()}"
    try:
        here.mkdir(parents=True, exist_ok=True)
        os.utime(here)  # most recently used
        versions = sorted((p for p in parent.glob(f"{_PREFIX}*") if p.is_dir()),
                          key=lambda p: p.stat().st_mtime, reverse=True)
        for old in versions[KEEP:]:
            if old != here:
                shutil.rmtree(old, ignore_errors=True)
    except OSError:  # not writable: numba warns and compiles without a cache
        pass
    return here


def njit(**options) -> Callable[[Callable], Callable]:
    """``numba.njit(**options)``; with ``cache=True`` the kernel's cache is
    :func:`cache_dir` (numba fixes a kernel's cache path when it is decorated, so the
    setting is made for the decoration only and the caller's own numba setting stays)."""
    decorate = numba.njit(**options)
    if not options.get("cache"):
        return decorate

    def apply(func: Callable) -> Callable:
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = str(cache_dir())
        try:
            return decorate(func)
        finally:
            numba.config.CACHE_DIR = saved

    return apply
