"""Command-line front end: `modesel <command> ...`.

Each command lives in its own module under `modesel.commands`; the module
defines `register(subparsers)` which adds a sub-parser and sets
`func(args) -> int` as its default. Errors the user can fix are
`ModeselError`s: printed as one line on stderr, exit code 2, no traceback
unless `--debug` is given.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from modesel.errors import ModeselError

# One entry per command module in modesel/commands/ (add yours here).
COMMANDS = (
    "candidates",
    "shapes",
    "simulate",
    "linearize",
    "derive",
    "run",
    "worker",
    "report",
    "export",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="modesel",
        description="Choose assumed-mode sets for reduced-order wind-turbine models.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"modesel.commands.{name}")
        except ModuleNotFoundError as exc:  # command not built yet in this checkout
            if exc.name != f"modesel.commands.{name}":
                raise
            continue
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except ModeselError as exc:
        if args.debug:
            raise
        print(f"modesel: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("modesel: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
