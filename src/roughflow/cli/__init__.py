"""The ``roughflow`` command line.

Each subcommand lives in its own module in this package and defines
``register(subparsers)``, which adds its parser and sets ``func`` to a
function taking the parsed arguments. Modules are discovered automatically.
Files are declared with ``_common.add_input``/``add_output``; :func:`main` checks the
outputs and reads the inputs before ``func`` runs and maps errors to exit statuses
(:data:`EXIT_STATUS`).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import pkgutil
import sys

from roughflow.errors import ConvergenceError, InputError

from ._common import check_outputs, read_inputs

#: Exit statuses of every subcommand (also in ``roughflow --help``).
EXIT_STATUS = {0: "success", 1: "unexpected error (a bug: please report the traceback)",
               2: "bad input: options, input files or output path (nothing was computed)",
               3: "a solver did not converge (its residual is printed)",
               4: "out of memory although the estimate fitted (roughflow.resources)",
               130: "interrupted"}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="roughflow",
        description="Contact, percolation and Reynolds flow of randomly rough surfaces.",
        epilog="exit status: " + "; ".join(f"{k} {v}" for k, v in EXIT_STATUS.items()),
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress to stderr")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(asctime)s %(name)s %(levelname)s: %(message)s",
    )
    name = f"roughflow {args.command}"
    try:
        check_outputs(args)
        read_inputs(args)
        args.func(args)
    except InputError as exc:
        parser.exit(2, f"{name}: error: {exc}\n")
    except ConvergenceError as exc:
        parser.exit(3, f"{name}: solver did not converge: {exc}\n")
    except MemoryError:
        parser.exit(4, f"{name}: out of memory (the estimate of roughflow.resources fitted "
                       "the available memory, which other processes may have taken since)\n")
    except KeyboardInterrupt:
        parser.exit(130, f"{name}: interrupted\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
