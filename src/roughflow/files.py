"""Files published whole and with the permissions of a newly created file.

A file is written under a temporary name beside its destination and renamed over it (atomic
on one file system), so a reader never sees half of it. ``tempfile.mkstemp`` makes the
temporary file 0600, which a group sharing results (or an FFTW wisdom directory) could not
read: :func:`publish` gives it 0666 less the umask first, as ``open`` would have.
"""

from __future__ import annotations

import os


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
