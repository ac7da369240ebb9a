"""The ``roughflow`` command line.

Each subcommand lives in its own module in this package and defines
``register(subparsers)``, which adds its parser and sets ``func`` to a
function taking the parsed arguments. Modules are discovered automatically.
Files are declared with ``_common.add_input``/``add_output``; :func:`main` checks the
outputs and reads the inputs before ``func`` runs and maps errors to exit statuses
(:data:`EXIT_STATUS`). ``args.provenance`` (:class:`roughflow.provenance.Provenance`)
carries the command line, start time and the inputs' history to ``write_dataset``.
``-v``/``-vv``/``-q`` work before or after the subcommand (:mod:`roughflow.progress`).

Only the standard library, :mod:`roughflow.defaults` and :mod:`roughflow.errors` are
imported to build the parser: numpy, xarray, pyFFTW, numba, pyamg and matplotlib are
imported by the subcommand that runs (``roughflow --help`` stays fast).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import pkgutil
import signal
import sys
import threading
from dataclasses import replace
from pathlib import Path

from roughflow import __version__
from roughflow.errors import ConvergenceError, InputError, OutputError
from roughflow.files import (
    TERMINATING_SIGNALS,
    Terminated,
    check_terminated,
    forget_terminated,
    on_terminating_signal,
)
from roughflow.progress import log_progress

from ._common import check_outputs, read_inputs

#: Exit statuses of every subcommand (also in ``roughflow --help``).
EXIT_STATUS = {0: "success", 1: "unexpected error (a bug: please report the traceback)",
               2: "bad input: options, input files or output path (nothing was computed), "
                  "or a surface whose threshold lies outside the search's pressure range",
               3: "a solver did not converge (its residual is printed)",
               4: "out of memory although the estimate fitted (roughflow.resources)",
               5: "an output could not be written (disk or quota full, folder unwritable); "
                  "none of the command's outputs was left",
               130: "interrupted",
               128 + int(signal.SIGPIPE): "the reader of the standard output went away "
                                          "(`roughflow cite | head`)",
               **{128 + int(s): f"terminated by {signal.Signals(s).name}"
                  + (" (kill, scancel, a time limit)" if s == signal.SIGTERM else "")
                  for s in TERMINATING_SIGNALS}}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="roughflow",
        description="Contact, percolation and Reynolds flow of randomly rough surfaces.",
        epilog="exit status: " + "; ".join(f"{k} {v}" for k, v in EXIT_STATUS.items()),
    )
    parser.add_argument("--version", action="version", version=f"roughflow {__version__}")
    _add_verbosity(parser, default=True)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        module.register(sub)
    for p in _subparsers(parser):
        _add_verbosity(p, default=False)
    for p in (parser, *_subparsers(parser)):
        # no prefixes of long options: `scene ladder --surface-energy 0.05` (the absolute
        # gamma_s of `contact`) was taken as --surface-energy-ratio, a different quantity
        p.allow_abbrev = False
    return parser


def _add_verbosity(parser: argparse.ArgumentParser, *, default: bool) -> None:
    """-v/-q on the main parser (with defaults) and on every subcommand (without: a value
    given after the subcommand then overrides, one not given leaves the main one)."""
    kw = {} if default else {"default": argparse.SUPPRESS}
    g = parser.add_argument_group("progress")
    g.add_argument("-v", "--verbose", action="count", help="log progress to stderr: -v one "
                   "line per solve, seed and step (INFO), -vv also solver steps (DEBUG)",
                   **({"default": 0} if default else kw))
    g.add_argument("-q", "--quiet", action="store_true", help="log errors only",
                   **({"default": False} if default else kw))


def _innermost(parser: argparse.ArgumentParser,
               args: argparse.Namespace) -> argparse.ArgumentParser:
    """The parser of the (sub)command that ``args`` chose (``scene ladder``: ladder's)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            chosen = action.choices.get(getattr(args, action.dest, None))
            if chosen is not None:
                return _innermost(chosen, args)
    return parser


def _subparsers(parser: argparse.ArgumentParser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for p in action.choices.values():
                yield p
                yield from _subparsers(p)


def _level(args: argparse.Namespace) -> int:
    if args.quiet:
        return logging.ERROR
    return {0: logging.WARNING, 1: logging.INFO}.get(args.verbose, logging.DEBUG)


def _failed_path(args: argparse.Namespace) -> Path | None:
    """Where a command keeps the inputs of a solve that did not converge: beside the output
    it would have written, ``OUTPUT.failed.npz`` (never mistaken for a result)."""
    output = getattr(args, "output", None)
    return None if output is None else Path(f"{output}.failed.npz")


def _save_failed(exc: ConvergenceError, args: argparse.Namespace) -> str:
    """Save the inputs of a failed solve (:func:`_failed_path`); the message's tail naming
    the file."""
    path = _failed_path(args)
    if not exc.inputs or path is None:
        return ""
    import numpy as np

    from roughflow.io import write_together

    def save(tmp: str) -> None:
        with open(tmp, "wb") as f:  # a file object: np.savez would append ".npz" to a name
            np.savez(f, **exc.inputs)

    try:  # atomic like every output; a full disk costs the saved inputs, not the message
        write_together([(Path(path), save)])
    except OSError as err:
        return f"; its inputs could not be saved ({err})"
    keys = ", ".join(k for k in exc.inputs if k != "gap")
    return f"; the failed solve's gap and {keys} are saved in {path}"


def _flush_stdout() -> None:
    """Flush what the command printed, so that a closed pipe raises inside :func:`main`
    (not at the interpreter's exit) and a full disk is an output error (exit 5)."""
    if sys.stdout is None:  # started with its standard output closed
        return
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        raise
    except OSError as exc:
        raise OutputError(f"the standard output could not be written ({exc})") from None


def _silence_stdout() -> None:
    """Point the process's real standard output at /dev/null (not a stream a host or a
    test put in its place, whose file descriptor is not ours to change)."""
    if sys.stdout is None or sys.stdout is not sys.__stdout__:
        return
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def main(argv: list[str] | None = None) -> int:
    from roughflow.fft import check_environment
    from roughflow.provenance import Provenance, input_history, input_references

    argv = sys.argv[1:] if argv is None else list(argv)
    provenance = Provenance.for_command(argv)
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # said by the subcommand's parser, with its usage, not the main one's
        _innermost(parser, args).error(f"unrecognized arguments: {' '.join(unknown)}")
    if args.quiet and args.verbose:  # before or after the subcommand alike
        parser.exit(2, f"roughflow {args.command}: error: -q (errors only) contradicts "
                       f"-{'v' * args.verbose} (progress)\n")
    log_progress(_level(args))
    name = f"roughflow {args.command}"
    # in the main thread only (signal's rule), and not for a signal a launcher set ignored
    handled = ([s for s in TERMINATING_SIGNALS if signal.getsignal(s) is not signal.SIG_IGN]
               if threading.current_thread() is threading.main_thread() else [])
    forget_terminated()
    previous = {s: signal.signal(s, on_terminating_signal) for s in handled}
    try:
        check_environment()  # FFT settings from the environment, before any work
        check_outputs(args)
        read_inputs(args)
        given = [v for v in args.data.values() if v is not None]
        single = [v for v in given if not isinstance(v, list)]
        listed = [d for v in given if isinstance(v, list) for d in v]
        # a derived file continues its input's history (CF; an aggregate lists its jobs
        # instead) and cites what its inputs cite
        args.provenance = replace(provenance, history=input_history(*single),
                                  references=input_references(*single, *listed))
        args.func(args)
        check_terminated()  # a signal whose exception Python dropped in a destructor
        _flush_stdout()
        stale = _failed_path(args)
        if stale is not None:  # an earlier failed attempt's inputs no longer apply
            stale.unlink(missing_ok=True)
    except InputError as exc:
        parser.exit(2, f"{name}: error: {exc}\n")
    except ConvergenceError as exc:
        parser.exit(3, f"{name}: solver did not converge: {exc}{_save_failed(exc, args)}\n")
    except MemoryError:
        parser.exit(4, f"{name}: out of memory (the estimate of roughflow.resources fitted "
                       "the available memory, which other processes may have taken since)\n")
    except OutputError as exc:
        parser.exit(5, f"{name}: error: {exc}\n")
    except KeyboardInterrupt:
        parser.exit(130, f"{name}: interrupted\n")
    except BrokenPipeError:
        # the reader of stdout went away (`roughflow cite | head`): a line on stderr, and
        # no second error when the interpreter flushes stdout at exit
        _silence_stdout()
        parser.exit(128 + int(signal.SIGPIPE), f"{name}: the standard output was closed "
                                                "by its reader\n")
    except Terminated as exc:
        parser.exit(128 + int(exc.signum),
                    f"{name}: terminated ({signal.Signals(exc.signum).name})\n")
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        forget_terminated()  # a library call after main() (a test, a notebook) starts clean
    return 0


if __name__ == "__main__":
    sys.exit(main())
