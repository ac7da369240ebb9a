"""The ``roughflow`` command line.

Each subcommand lives in its own module in this package and defines
``register(subparsers)``, which adds its parser and sets ``func`` to a
function taking the parsed arguments. Modules are discovered automatically.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import pkgutil
import sys

from roughflow.errors import ConvergenceError, InputError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="roughflow",
        description="Contact, percolation and Reynolds flow of randomly rough surfaces.",
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
    try:
        args.func(args)
    except InputError as exc:
        parser.exit(2, f"roughflow {args.command}: error: {exc}\n")
    except ConvergenceError as exc:
        parser.exit(3, f"roughflow {args.command}: solver did not converge: {exc}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
