"""Command-line front end: `modesel <command> ...`.

Each command lives in its own module under `modesel.commands`; the module
defines `register(subparsers)` which adds a sub-parser and sets
`func(args) -> int` as its default. Errors the user can fix are
`ModeselError`s: printed as one line on stderr, exit code 2, no traceback
unless `--debug` is given; command-line syntax errors are one line too.
SIGTERM is handled like SIGINT (Ctrl-C): the command stops gracefully
(`modesel run` keeps the finished trials and writes their results), prints
one line and exits with 143 (SIGTERM) or 130 (SIGINT).
"""
from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys

from modesel.errors import Interrupted, ModeselError


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds like Ctrl-C."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors ('modesel: error: ...', exit code 2)."""

    def error(self, message):
        command = self.prog.split(" ", 1)[1] if " " in self.prog else ""
        where = f"{command}: " if command else ""
        print(f"modesel: error: {where}{' '.join(message.split())} (see `{self.prog} --help`)",
              file=sys.stderr)
        raise SystemExit(2)


def _terminate(signum, frame):
    raise Terminated()

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
    "docs",
)


def _command_of(argv) -> str | None:
    """The command named by `argv` (its first word after the global options),
    None when none is named."""
    for word in argv:
        if word == "--":
            return None
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or of `command` only: each command
    module imports what its command needs (`modesel simulate` need not import
    the candidate families, Optuna or SymPy)."""
    parser = _Parser(
        prog="modesel",
        description="Choose assumed-mode sets for reduced-order wind-turbine models.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in (command,) if command else COMMANDS:
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
    # The engine's matrices have a few hundred rows at most: OpenBLAS worker
    # threads only add synchronisation (measured 40-100 ms instead of 0.3 ms per
    # right-hand side on a loaded machine, README "Benchmarks"). One thread for
    # the whole command (linearize, workers, reports) unless the user set it;
    # effective only before numpy is first imported, as here.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    parser = build_parser(_command_of(argv))
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    previous = _handle_sigterm()
    try:
        return int(args.func(args) or 0)
    except Interrupted as exc:
        if args.debug:
            raise
        print(f"modesel: {exc}", file=sys.stderr)
        return exc.exit_code
    except ModeselError as exc:
        if args.debug:
            raise
        print(f"modesel: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt as exc:
        if args.debug:
            raise
        terminated = isinstance(exc, Terminated)
        print(f"modesel: interrupted ({'SIGTERM' if terminated else 'SIGINT'})", file=sys.stderr)
        return 143 if terminated else 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _handle_sigterm():
    """Turn SIGTERM into `Terminated` in the main thread; returns the previous
    handler (None when not in the main thread, where signals cannot be set)."""
    try:
        return signal.signal(signal.SIGTERM, _terminate)
    except ValueError:
        return None


if __name__ == "__main__":
    raise SystemExit(main())
