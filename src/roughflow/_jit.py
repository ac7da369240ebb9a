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
written, in a private folder of the temporary folder (with a warning: a group's shared cache
whose folders another user made under umask 022 is passed over); where neither can, the
kernels are compiled in every process, with a warning too (never cached beside their source
files, numba's fallback, which is per file: a kernel whose cache numba put anywhere else is
left uncached).

Many jobs of a sweep start at once on one cache. numba's save reads a folder's index, picks
the next data file and rewrites the index; two processes saving at once gave two signatures
the same data file and lost one index entry (numba issues 4807 and 10128), and a third
process could load one signature's machine code for another's (on a cluster of several CPU
types, code built for another CPU). Saves are therefore serialised by a lock file in the
version's folder (flock; unlocked where the file system has none), and a save that fails (a
full disk or quota, a folder pruned meanwhile) leaves the kernel uncached instead of failing
the computation. A save that found the lock held for :data:`SAVE_LOCK_WAIT_S` (its holder
stopped, perhaps another user's job of a shared cache) leaves the process's later kernels
uncached at once, without waiting again, until the lock is free.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import logging
import os
import pickle
import shutil
import stat
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numba

from roughflow.files import (
    STALE_TEMPORARY_S,
    flock_within,
    open_lock_file,
    remove_stale,
    user_cache_dir,
    waited_in_vain,
)

log = logging.getLogger(__name__)

#: Versions of the compiled kernels kept ...
KEEP = 4
#: ... and the time (s) a version must have gone unused before it is removed: a long job
#: of an older checkout may still load from it.
PRUNE_AFTER_S = 86400.0
#: How long (s) a save waits for another process's save before it gives up (the kernel then
#: stays uncached): a holder stopped or hung (SIGSTOP, a suspended job, a stalled network
#: file system) must not stop every other job of this version.
SAVE_LOCK_WAIT_S = 60.0
#: The lock file of a version's folder that serialises saves.
_SAVE_LOCK = ".save.lock"
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


def _parents() -> Iterator[Path]:
    """Where the versions may live, the preferred place first; the spare one in the shared
    temporary folder only if it is this user's own private folder (its name can be
    guessed: another user could make it first and plant pickled machine code in it), and
    made only when it is asked for (every process made it, used or not)."""
    given = os.environ.get("NUMBA_CACHE_DIR")
    first = Path(given).expanduser() / "roughflow" if given else user_cache_dir("numba")
    if first is not None:
        yield first
    spare = Path(tempfile.gettempdir()) / f"roughflow-numba-{os.getuid()}"
    if _private(spare):
        yield spare


def _private(folder: Path) -> bool:
    """Whether ``folder`` is (or has just been made) a real folder of this user that no
    one else may write."""
    try:
        folder.mkdir(mode=0o700, exist_ok=True)
        st = folder.lstat()  # a link is refused, not followed
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid():
            return False
        if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            # this user's own, made under a umask of 002 (as before this rule): made private
            folder.chmod(0o700)
    except OSError:
        return False
    return True


def _unwritable(folder: Path) -> OSError | None:
    """Why no file can be made in ``folder`` (made if missing); None where one can."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder):
            pass
    except OSError as err:
        return err
    return None


def _prune(parent: Path, here: Path) -> None:
    """Remove versions beyond the :data:`KEEP` most recently used ones that have gone
    unused for :data:`PRUNE_AFTER_S`."""
    try:
        entries = [p for p in parent.iterdir() if p.is_dir()]
        # a prune interrupted mid-way left its folder moved aside (".<version>.removing-<pid>")
        for p in entries:
            if p.name.startswith(".") and p.stat().st_mtime < time.time() - STALE_TEMPORARY_S:
                shutil.rmtree(p, ignore_errors=True)
        versions = sorted((p for p in entries if not p.name.startswith(".")),
                          key=lambda p: p.stat().st_mtime, reverse=True)
        old = time.time() - PRUNE_AFTER_S
        for p in versions[KEEP:]:
            # another user's version that this one may not empty (made under umask 022 in
            # a group's shared cache) is left to its owner: moved aside, it would stay
            # behind as a ".removing" folder
            if (p != here and p.stat().st_mtime < old
                    and os.access(p, os.W_OK | os.X_OK, effective_ids=True)):
                # moved aside in one step first: a process that starts on this version
                # meanwhile finds it gone and compiles afresh, instead of loading from a
                # folder that is being emptied
                gone = parent / f".{p.name}.removing-{os.getpid()}"
                p.rename(gone)
                shutil.rmtree(gone, ignore_errors=True)
    except OSError:  # another process pruned at the same time
        pass


@functools.cache
def cache_dir() -> Path | None:
    """This package version's kernel cache (None: no writable place, no cache)."""
    try:
        key = source_key()
    except OSError:
        return None
    refused = []
    for parent in _parents():
        here = parent / key
        err = _unwritable(here)
        if err is not None:
            refused.append(f"{here} ({err.strerror or err})")
            continue
        if refused:  # a cache the user set up (a group's NUMBA_CACHE_DIR) is not in use
            log.warning("compiled kernels: cannot write %s; they are cached in %s",
                        "; ".join(refused), here)
        with contextlib.suppress(OSError):  # pruned by another process meanwhile
            os.utime(here)  # most recently used
        _prune(parent, here)
        return here
    log.warning("compiled kernels: cannot write %s; they are compiled in every process",
                "; ".join(refused) or "any cache folder")
    return None


def njit(**options) -> Callable[[Callable], Callable]:
    """``numba.njit(**options)``; with ``cache=True`` the kernel's cache is
    :func:`cache_dir` (numba fixes a kernel's cache path when it is decorated, so the
    setting is made for the decoration only and the caller's own numba setting stays)."""
    if not options.get("cache"):
        return numba.njit(**options)
    if options.get("signature_or_function") is not None:
        # numba compiles and saves such a kernel while decorating it, before its cache can
        # be checked and its saves locked (:func:`_guard`)
        raise ValueError("roughflow._jit.njit(cache=True) takes no explicit signatures")
    where = cache_dir()
    if where is None:
        return numba.njit(**{**options, "cache": False})
    decorate = numba.njit(**options)

    def apply(func: Callable) -> Callable:
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = str(where)
        try:
            kernel = decorate(func)
        finally:
            numba.config.CACHE_DIR = saved
        cache = getattr(kernel, "_cache", None)
        if cache is not None:
            _guard(cache, where)
        return kernel

    return apply


def _guard(cache, where: Path) -> None:
    """Keep numba's cache of one kernel in ``where`` or nowhere, and its saves locked and
    harmless (module docstring)."""
    if not Path(cache.cache_path).is_relative_to(where):
        # numba could not use ``where`` when the kernel was decorated (the folder pruned
        # or full) and fell back to a cache of its own, beside the source file: the cache
        # that follows that file only, which this module exists to avoid
        log.debug("%s: numba chose %s; the kernel is not cached", cache, cache.cache_path)
        cache.disable()
        return
    load, save = cache.load_overload, cache.save_overload
    folder = Path(cache.cache_path)

    def load_overload(sig, target_context):
        try:
            return load(sig, target_context)
        except (EOFError, pickle.UnpicklingError) as err:
            # an index cut short (numba does not fsync: a node that crashed while writing)
            # made every later run fail; it is a cache miss, and the save replaces it
            log.warning("numba's cache in %s is damaged (%s): the kernel is compiled",
                        folder, err)
            return None

    def save_overload(sig, data) -> None:
        try:
            # after one vain wait, every kernel of a search waited its full minute behind a
            # stopped holder: later saves try the lock once (files.flock_within)
            tried_before = waited_in_vain(where / _SAVE_LOCK)
            with _save_lock(where) as locked:
                if not locked and tried_before:  # said once, for the first kernel
                    log.debug("%s: %s is still held; the kernel is not cached", cache,
                              where / _SAVE_LOCK)
                    return
                if not locked:
                    raise TimeoutError(f"another process held {where / _SAVE_LOCK} for "
                                       f"{SAVE_LOCK_WAIT_S:g} s; this process's later "
                                       "kernels are not cached while it holds it")
                remove_stale(folder.glob("*.tmp.*"))  # numba's, of a killed save
                try:
                    save(sig, data)
                except (EOFError, pickle.UnpicklingError):
                    _remove_index(cache)  # damaged (see load_overload): made afresh
                    save(sig, data)
        except (OSError, EOFError, pickle.UnpicklingError) as err:
            log.warning("a compiled kernel could not be cached in %s (%s): it is compiled "
                        "again by the next process", where, err)

    cache.load_overload, cache.save_overload = load_overload, save_overload


def _remove_index(cache) -> None:
    index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
    if index is not None:
        with contextlib.suppress(OSError):
            os.unlink(index)


@contextlib.contextmanager
def _save_lock(folder: Path) -> Iterator[bool]:
    """An exclusive lock of ``folder``'s ``.save.lock`` between processes while numba
    updates its index there. Yields False if another process held it for
    :data:`SAVE_LOCK_WAIT_S` (at once, once this process has waited for it in vain); True
    once held, and also where the platform or the file system has no flock (the save then
    goes on unlocked, as numba's own does)."""
    try:
        import fcntl  # noqa: F401  (flock_within's)
    except ImportError:
        yield True
        return
    fd = None
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd = open_lock_file(folder / _SAVE_LOCK)  # a group may share the cache
    except OSError as err:
        log.debug("saving unlocked: cannot open a lock file in %s (%s)", folder, err)
    try:
        held = fd is None
        if not held:
            try:
                held = flock_within(fd, folder / _SAVE_LOCK, SAVE_LOCK_WAIT_S)
            except OSError as err:  # a file system without flock
                log.debug("saving unlocked: cannot lock %s (%s)", folder, err)
                held = True
        yield held
    finally:
        if fd is not None:
            os.close(fd)  # releases the lock
