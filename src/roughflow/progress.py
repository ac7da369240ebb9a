"""Progress reports: roughflow logs what it does to the ``roughflow`` logger.

- INFO: one line per contact solve of a threshold search, a pressure ladder or the channels
  scene (load, contact area, iterations, residual, seconds: ``roughflow.search.load``), per
  seed and step of a scene, per command;
- DEBUG: in addition, every :data:`~roughflow.defaults.SOLVER_LOG_EVERY` steps of a contact
  solve (step, residual, contact fraction; FIRE also its time step; the default hard-wall CG
  its free residual estimate, the exact residual being computed only near convergence, and
  its trial step).

The command line shows them with ``-v`` (INFO) or ``-vv`` (DEBUG), before or after the
subcommand; a script or notebook calls :func:`log_progress`, or configures the standard
``logging`` module itself (the records have the usual names, ``roughflow.<module>``).
"""

from __future__ import annotations

import logging
import sys
from typing import TextIO

FORMAT = "%(asctime)s %(name)s %(levelname)s: %(message)s"


class _ProgressHandler(logging.StreamHandler):
    """The handler :func:`log_progress` installs (so that a second call replaces it)."""


def log_progress(level: int | str | None = "INFO", stream: TextIO | None = None
                 ) -> logging.Handler | None:
    """Print roughflow's progress at ``level`` ("INFO", "DEBUG", ...) to ``stream`` (default
    standard error; each record is flushed at once) and return the handler. A second call
    replaces the first; ``log_progress(None)`` turns it off again.

    >>> import roughflow
    >>> roughflow.log_progress("INFO")          # doctest: +SKIP
    """
    logger = logging.getLogger("roughflow")
    for h in [h for h in logger.handlers if isinstance(h, _ProgressHandler)]:
        logger.removeHandler(h)
    if level is None:
        logger.setLevel(logging.NOTSET)
        logger.propagate = True
        return None
    handler = _ProgressHandler(sys.stderr if stream is None else stream)
    handler.setFormatter(logging.Formatter(FORMAT, datefmt="%H:%M:%S"))
    logger.addHandler(handler)
    logger.setLevel(level.upper() if isinstance(level, str) else level)
    # records go to this handler only (a root handler, e.g. logging.basicConfig in a
    # notebook, would print each line twice)
    logger.propagate = False
    return handler
