"""Files published whole and with the permissions of a newly created file, and the signals
that end a command (held back while a set of files is published).

A file is written under a temporary name beside its destination and renamed over it (atomic
on one file system), so a reader never sees half of it. ``tempfile.mkstemp`` makes the
temporary file 0600, which a group sharing results (or an FFTW wisdom directory) could not
read: :func:`publish` gives it 0666 less the umask first, as ``open`` would have.
"""

from __future__ import annotations

import contextlib
import glob
import os
import signal
import stat
import time
from collections.abc import Iterable, Iterator
from pathlib import Path

from roughflow.errors import InputError

#: Age (s) after which a temporary file that a cache's writer left is taken as that of a
#: killed process (SIGKILL, out of memory), not one still being written.
STALE_TEMPORARY_S = 3600.0

#: Signals that end a command, whose default action would stop it where it stands: SIGTERM
#: (kill, scancel, a time limit), SIGHUP (a closed terminal), SIGUSR1 and SIGUSR2 (what
#: SLURM's --signal sends ahead of a time limit). The command line turns them into an
#: exception (:func:`on_terminating_signal`), so that temporary files are removed on the way
#: out.
TERMINATING_SIGNALS = tuple(getattr(signal, name) for name in
                            ("SIGTERM", "SIGHUP", "SIGUSR1", "SIGUSR2") if hasattr(signal, name))


class Terminated(BaseException):
    """A terminating signal (:data:`TERMINATING_SIGNALS`), turned into an exception so that
    temporary files are removed on the way out, as they are for Ctrl-C (the default action
    ends the process where it stands)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: The terminating signals this process has received (signals are delivered to a process:
#: this is process state by nature), in order; the command line clears it when it starts.
_RECEIVED: list[int] = []


def on_terminating_signal(signum: int, frame: object) -> None:
    """The handler of :data:`TERMINATING_SIGNALS` that the command line installs: notes the
    signal and raises :class:`Terminated` where the program stands. Python drops an
    exception raised inside a destructor or a weakref callback (it prints "Exception
    ignored"): a command then finished and exited 0 (2 of 8 SIGTERMs to a threshold scene,
    a crash audit); the note keeps the request, and :func:`check_terminated` raises it again
    before any output is published."""
    _RECEIVED.append(signum)
    raise Terminated(signum)


def check_terminated() -> None:
    """Raise :class:`Terminated` if a terminating signal has arrived since
    :func:`forget_terminated` (one whose exception was dropped on the way)."""
    if _RECEIVED:
        raise Terminated(_RECEIVED[0])


def forget_terminated() -> None:
    """Clear the signals :func:`on_terminating_signal` noted (a command starting afresh)."""
    _RECEIVED.clear()


#: What :func:`signals_held` holds back: the terminating signals and Ctrl-C.
HELD_SIGNALS = frozenset({*TERMINATING_SIGNALS, signal.SIGINT})


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Hold :data:`HELD_SIGNALS` back (POSIX, this thread) while netCDF files are read or
    written and published; a signal that arrives meanwhile is delivered afterwards. Raised
    inside netCDF4's and HDF5's code, its exception left xarray's file lock held, and the
    cleanup of the write then waited for that lock forever (3 of 7 SIGTERMs to an
    ``aggregate`` while it wrote: hung 20 minutes until a second signal)."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, HELD_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def raise_if_stopping() -> None:
    """Raise what a signal held back by :func:`signals_held` will raise once delivered
    (:class:`Terminated` under :func:`on_terminating_signal`, KeyboardInterrupt under
    Python's Ctrl-C handler; another handler's signal is left to it), or a terminating
    signal whose exception was dropped (:func:`check_terminated`): called before outputs
    are published, so that a command told to stop publishes nothing."""
    check_terminated()
    if not hasattr(signal, "sigpending"):
        return
    for signum in sorted(signal.sigpending() & HELD_SIGNALS):
        handler = signal.getsignal(signum)
        if handler is on_terminating_signal:
            raise Terminated(signum)
        if handler is signal.default_int_handler:
            raise KeyboardInterrupt


def new_file_mode() -> int:
    """The mode ``open`` gives a new file: 0666 less the process's umask."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def publish(tmp: str | os.PathLike, path: str | os.PathLike) -> None:
    """Give the finished temporary file ``tmp`` the permissions of a newly created file and
    rename it to ``path``."""
    os.chmod(tmp, new_file_mode())
    os.replace(tmp, path)


def user_cache_dir(name: str) -> Path | None:
    """roughflow's cache folder ``name`` of this user: ``$XDG_CACHE_HOME/roughflow/<name>``,
    else ``~/.cache/roughflow/<name>``; None where there is no home directory (HOME unset
    and a user id the password database does not know, as in some containers: ``~`` stays
    ``~``)."""
    base = os.environ.get("XDG_CACHE_HOME")
    if base:
        return Path(base) / "roughflow" / name
    home = os.path.expanduser("~")
    return Path(home) / ".cache" / "roughflow" / name if os.path.isabs(home) else None


def open_lock_file(lock: Path) -> int:
    """A descriptor of the lock file ``lock`` (made if missing) for ``fcntl.flock``: readable
    and writable by those the umask allows, so that a group can share the folder; another
    user's lock file opens read-only (flock needs no write permission). Raises OSError."""
    try:
        return os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
    except PermissionError:
        return os.open(lock, os.O_RDONLY)


#: Lock files that another process held for a whole wait of this one: later waits on them
#: try once, without waiting again, until the lock is taken (its holder may be stopped, a
#: suspended job or another user's, which this process cannot end).
_WAITED_IN_VAIN: set[Path] = set()


def waited_in_vain(lock: Path) -> bool:
    """Whether this process waited for ``lock`` in vain and has not taken it since."""
    return lock in _WAITED_IN_VAIN


def flock_within(fd: int, lock: Path, wait_s: float) -> bool:
    """Take the exclusive flock of ``fd``, open on the lock file ``lock``, trying for
    ``wait_s`` (once, where :func:`waited_in_vain`); whether it was taken. Raises OSError
    where the file system has no flock (the callers go on unlocked)."""
    import fcntl

    deadline = time.monotonic() + (0.0 if lock in _WAITED_IN_VAIN else wait_s)
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if time.monotonic() >= deadline:
                _WAITED_IN_VAIN.add(lock)
                return False
            time.sleep(0.05)
        else:
            _WAITED_IN_VAIN.discard(lock)  # the holder went on: wait again next time
            return True


def require_readable(path: Path, source: str, *, missing: str = "") -> None:
    """:class:`InputError` naming ``source`` (the role and name of ``path``) unless it is a
    file this user may read: missing (``missing`` appended: a hint), a directory, or refused
    (another user's file, or a folder above it that this user may not enter). The readers
    behind it reported a refusal as a traceback or as a file of an unknown format."""
    try:
        if not path.exists():
            raise InputError(f"{source} does not exist{missing}")
        if path.is_dir():
            raise InputError(f"{source} is a directory, not a file")
        with path.open("rb"):
            pass
    except PermissionError as exc:
        raise InputError(f"{source} cannot be read: {denied(exc)}") from None


def sticky_owner(path: Path) -> int | None:
    """The owner of an existing ``path`` that this user may not replace because its folder
    has the sticky bit (/tmp, a shared scratch folder: only the file's owner, the folder's
    owner or root may replace or remove a file there); None where a rename over it is not
    refused for that reason."""
    try:
        st, folder = path.lstat(), path.parent.stat()
    except OSError:  # no such file: nothing to replace
        return None
    if folder.st_mode & stat.S_ISVTX and os.geteuid() not in (0, st.st_uid, folder.st_uid):
        return st.st_uid
    return None


def user_name(uid: int | None = None) -> str:
    """The name of user ``uid`` (default: this process's effective user), for messages."""
    if uid is None:
        if not hasattr(os, "geteuid"):
            return "this user"
        uid = os.geteuid()
    try:
        import pwd

        return pwd.getpwuid(uid).pw_name
    except (ImportError, KeyError):  # not POSIX, or a user id the password database lacks
        return f"uid {uid}"


def denied(exc: PermissionError) -> str:
    """Why ``exc`` refused a path, for a message: the user it refused, who may not be the
    one who made the file (a lab's shared results, a cluster's software tree)."""
    return (f"{exc.strerror or 'permission denied'} for user {user_name()} (check the "
            "permissions of the file and of each folder above it)")


def remove_stale(paths: Iterable[Path], older_than_s: float = STALE_TEMPORARY_S) -> None:
    """Remove those of ``paths`` (temporary files a killed writer left) last modified more
    than ``older_than_s`` ago; any that vanish meanwhile or cannot be removed are skipped."""
    old = time.time() - older_than_s
    for path in paths:
        with contextlib.suppress(OSError):
            if path.stat().st_mtime < old:
                path.unlink()


def part_prefix(path: Path) -> str:
    """How the name of a temporary file written for ``path`` begins: hidden, and naming the
    file it will become, so that a killed writer's leftover is known as ``path``'s."""
    return f".{path.name}."


def remove_stale_parts(path: Path) -> None:
    """Remove the temporary files of ``path`` (:func:`part_prefix`, ``.part``) that a killed
    writer (SIGKILL, out of memory) left more than :data:`STALE_TEMPORARY_S` ago: every
    command left one per kill and a re-run removed none (a 2048^2 surface leaves 33 MB)."""
    remove_stale(path.parent.glob(glob.escape(part_prefix(path)) + "*.part"))
