"""Provenance: which roughflow made a dataset, how, when and from what.

``roughflow.io.write_dataset`` (the single writer of every netCDF file) adds
:meth:`Provenance.attrs` to every dataset it writes:

- ``roughflow_version``, ``roughflow_commit`` (:func:`source_commit`: the git commit of the
  source that ran, ``-dirty`` where the package differs from it; absent for an installed
  release, whose version says it all, and for a checkout git refuses to read because
  another user owns it, with a warning), ``python_version``, ``backend`` ("cpu", or the
  CuPy version and GPU model of ``--backend cupy``), ``fft_threads``,
  ``fftw_effort`` (FFTW's planner effort: its algorithms set the round-off);
- ``command``: the command line (``roughflow contact s.nc ...``) or, for the Python API,
  the process's ``sys.argv``;
- ``created`` (ISO 8601, UTC) and ``wall_time_s`` (seconds from the start of the command
  to the write);
- ``history`` (CF convention): the history of the input file(s) plus one line
  ``<created>: <command> (roughflow <version>)``;
- ``references``: keys of :mod:`roughflow.citation` behind the methods used
  (``roughflow cite FILE.nc`` prints them);
- ``study_config`` (workflow study datasets): the study's config block as JSON; the job
  files record their own parameters in ``job_parameters`` (``roughflow.scenes.run``).
  A study dataset computes nothing itself: its ``backend``, ``fft_threads`` and
  ``fftw_effort`` are those of its jobs (:func:`settings_of_inputs`; "mixed: a, b" where
  they differ), and ``jobs_roughflow_commit`` the commits the jobs ran.

:data:`PROVENANCE_ATTRS` are the attributes that differ between two runs of the same
computation; comparisons of datasets ignore them (and ``wall_time``).
"""

from __future__ import annotations

import functools
import logging
import platform
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

from roughflow.defaults import DEFAULT_BACKEND

__all__ = ["PROVENANCE_ATTRS", "COMPUTE_ATTRS", "PACKAGE_DIR", "source_commit", "Provenance",
           "settings_of_inputs", "input_history", "input_references"]

#: Attributes written by :meth:`Provenance.attrs` (never copied from one file into another).
PROVENANCE_ATTRS = ("roughflow_version", "roughflow_commit", "python_version", "backend",
                    "fft_threads", "fftw_effort", "command", "created", "wall_time_s", "history",
                    "references", "study_config", "jobs_roughflow_commit")
#: How a file's numbers were computed; a file that only combines others records theirs.
COMPUTE_ATTRS = ("backend", "fft_threads", "fftw_effort")


log = logging.getLogger(__name__)

#: the package directory whose source :func:`source_commit` describes
PACKAGE_DIR = Path(__file__).resolve().parent


@functools.cache
def source_commit(package_dir: Path = PACKAGE_DIR) -> str:
    """The git commit of the checkout ``package_dir`` is tracked in, with ``-dirty`` where its
    tracked files there differ from that commit; "" where it is not tracked by git (an
    installed wheel, a virtualenv inside another repository) or git is missing. The version
    number alone cannot tell a result computed before a change of the numerics from one
    computed after it; once per process (two git calls, about 10 ms)."""
    def git(*args: str) -> str:
        # --no-optional-locks: status would refresh the index under .git/index.lock, which
        # a user's own git command running meanwhile then finds taken
        return subprocess.run(["git", "--no-optional-locks", "-C", str(package_dir), *args],
                              capture_output=True,
                              text=True, timeout=30, check=True).stdout.strip()

    try:
        # tracked here, not merely inside some other repository's tree
        git("ls-files", "--error-unmatch", "__init__.py")
        commit = git("rev-parse", "HEAD")
        changed = git("status", "--porcelain", "--untracked-files=no", "--", ".")
    except subprocess.CalledProcessError as err:
        if "dubious ownership" in (err.stderr or ""):
            # a checkout another user owns (a lab's shared one): git >= 2.35.2 refuses it,
            # since its configuration could run commands as this user; whether to trust
            # it is the user's decision, not roughflow's, but not one to take silently
            log.warning("the results do not record roughflow's git commit: git refuses the "
                        "checkout of %s, which belongs to another user (`git config --global "
                        "--add safe.directory <its top folder>` trusts it)", package_dir)
        return ""
    except (OSError, subprocess.SubprocessError):
        return ""
    return commit + ("-dirty" if changed else "")


@dataclass(frozen=True)
class Provenance:
    """How a dataset is being made. ``started``: ``time.time()`` when the work began
    (None: no wall time); ``threads``: FFT threads (None: ``ROUGHFLOW_FFT_THREADS`` or
    1); ``history``: the CF history of the inputs; ``references``: keys of
    :data:`roughflow.citation.REFERENCES`; ``study_config``: JSON of a study block;
    ``backend``: where the solves ran (``roughflow.gpu.describe``); ``from_inputs``:
    attributes that describe how the inputs were computed, for a dataset that computes
    nothing (:func:`settings_of_inputs`), in place of this process's."""

    command: str = field(default_factory=lambda: "python " + shlex.join(sys.argv))
    started: float | None = None
    threads: int | None = None
    history: str = ""
    references: tuple[str, ...] = ()
    study_config: str = ""
    backend: str = DEFAULT_BACKEND
    from_inputs: tuple[tuple[str, str | int], ...] = ()

    @classmethod
    def for_command(cls, argv: list[str]) -> Provenance:
        """The provenance of ``roughflow argv``, started now."""
        return cls(command="roughflow " + shlex.join(argv), started=time.time())

    def using(self, *methods: str) -> Provenance:
        """A copy that also records the references of ``methods``
        (:data:`roughflow.citation.METHODS`)."""
        from roughflow.citation import keys_for

        return replace(self, references=tuple(dict.fromkeys((*self.references,
                                                              *keys_for(*methods)))))

    def attrs(self) -> dict:
        """The netCDF attributes (module docstring)."""
        from roughflow import __version__
        from roughflow.fft import default_threads, effort

        now = datetime.now(UTC)
        created = now.isoformat(timespec="seconds")
        line = f"{created}: {self.command} (roughflow {__version__})"
        out = {
            "roughflow_version": __version__,
            **({"roughflow_commit": commit} if (commit := source_commit()) else {}),
            "python_version": platform.python_version(),
            "backend": self.backend,
            "fft_threads": self.threads if self.threads is not None else default_threads(),
            "fftw_effort": effort(),
            "command": self.command,
            "created": created,
            "history": f"{self.history}\n{line}" if self.history else line,
        }
        if self.started is not None:
            out["wall_time_s"] = round(now.timestamp() - self.started, 3)
        if self.references:
            out["references"] = " ".join(self.references)
        if self.study_config:
            out["study_config"] = self.study_config
        if self.from_inputs:
            for key in COMPUTE_ATTRS:  # not this process's: it computed nothing
                out.pop(key, None)
            out.update(self.from_inputs)
        return out


def settings_of_inputs(*datasets) -> tuple[tuple[str, str | int], ...]:
    """What the input datasets record of how they were computed (:data:`COMPUTE_ATTRS`, and
    their ``roughflow_commit`` as ``jobs_roughflow_commit``, or the one a study dataset
    passes on from its jobs): each value where all agree, "mixed: a, b" where they differ
    (a study whose jobs ran with other settings). A fit of a study so records its jobs'
    settings, not those of the fit's own process, which computed no transform."""
    out: list[tuple[str, str | int]] = []

    def value(ds, key: str):
        attrs = getattr(ds, "attrs", {})
        if key == "roughflow_commit" and "jobs_roughflow_commit" in attrs:
            return attrs["jobs_roughflow_commit"]
        return attrs.get(key)

    for key, name in (*((k, k) for k in COMPUTE_ATTRS),
                      ("roughflow_commit", "jobs_roughflow_commit")):
        values = {str(v): v for ds in datasets if (v := value(ds, key)) is not None}
        if len(values) == 1:
            out.append((name, next(iter(values.values()))))
        elif values:
            out.append((name, "mixed: " + ", ".join(sorted(values))))
    return tuple(out)


def input_history(*datasets) -> str:
    """The CF ``history`` lines of input datasets (in order, each line once)."""
    lines: list[str] = []
    for ds in datasets:
        text = str(getattr(ds, "attrs", {}).get("history", ""))
        lines += [ln for ln in text.splitlines() if ln and ln not in lines]
    return "\n".join(lines)


def input_references(*datasets) -> tuple[str, ...]:
    """The ``references`` keys the input datasets record (in order, each once)."""
    keys: list[str] = []
    for ds in datasets:
        keys += str(getattr(ds, "attrs", {}).get("references", "")).split()
    return tuple(dict.fromkeys(keys))
