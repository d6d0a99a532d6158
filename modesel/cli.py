"""Command-line front end: `modesel <command> ...`.

Each command lives in its own module under `modesel.commands`; the module
defines `register(subparsers)` which adds a sub-parser and sets
`func(args) -> int` as its default. Errors the user can fix are
`ModeselError`s: printed as one line on stderr, exit code 2, no traceback
unless `--debug` is given; command-line syntax errors are one line too.
SIGTERM is handled like SIGINT (Ctrl-C): the command stops gracefully
(`modesel run` keeps the finished trials and writes their results), prints
one line and exits with 143 (SIGTERM) or 130 (SIGINT).

Python drops an exception raised where it cannot propagate: in a ctypes
callback (llvmlite's object cache, called back while numba compiles), a
weakref callback (importlib's module locks), a `__del__`. A signal that lands
there would be printed as "Exception ignored ..." and lost, and the code it
interrupted may be left half-done (numba then fails later with an unrelated
error). So: the handler does not raise while llvmlite code is on the stack
but sends the signal again a moment later (to this process); a
KeyboardInterrupt dropped anywhere else reaches `sys.unraisablehook`, which
sends the signal again the same way; and an error that ends a command after
a signal was received is reported as the interruption it follows.
"""
from __future__ import annotations

import argparse
import functools
import importlib
import os
import signal
import sys
import threading

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


# Signals received during this command (names), for the report of an error
# that follows one (module doc).
RECEIVED: list[str] = []
_RUNNING = threading.Event()    # set while `main` runs a command

# Packages whose Python code may run inside C callbacks, where a raised
# exception is dropped: a signal is put off while their code is on the stack.
_CALLBACK_MODULES = ("llvmlite.",)
REDELIVER_S = 0.05


def _in_callback(frame) -> bool:
    """Whether `frame` or a caller is code of `_CALLBACK_MODULES` (the callback
    itself, or what it calls, such as numba's cache hook)."""
    while frame is not None:
        if str(frame.f_globals.get("__name__", "")).startswith(_CALLBACK_MODULES):
            return True
        frame = frame.f_back
    return False


def _on_signal(signum, frame):
    """SIGINT / SIGTERM in the main thread: raise KeyboardInterrupt /
    `Terminated`, unless C callback code is running (module doc): then
    deliver the signal again in `REDELIVER_S`."""
    name = "SIGTERM" if signum == signal.SIGTERM else "SIGINT"
    if _in_callback(frame):
        _send_again(signum)
        return
    RECEIVED.append(name)
    raise Terminated() if name == "SIGTERM" else KeyboardInterrupt()


def _send_again(signum):
    """Send `signum` to this process in `REDELIVER_S`, if the command still runs then."""
    def send():
        if _RUNNING.is_set():
            os.kill(os.getpid(), signum)
    timer = threading.Timer(REDELIVER_S, send)
    timer.daemon = True
    timer.start()


def _unraisable(info, previous=None):
    """`sys.unraisablehook` during a command: a KeyboardInterrupt that Python
    dropped (module doc) is sent again; anything else goes to `previous`."""
    if isinstance(info.exc_value, KeyboardInterrupt) and _RUNNING.is_set():
        _send_again(signal.SIGTERM if isinstance(info.exc_value, Terminated) else signal.SIGINT)
        return
    (previous or sys.__unraisablehook__)(info)

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
    "serve",
)
#: commands whose module is not `modesel.commands.<name>`: `serve` runs
#: `main` in its children, so it sits above this module (modesel.server)
COMMAND_MODULES = {"serve": "modesel.server"}


def command_of(argv) -> str | None:
    """The command named by `argv` (its first word after the global options),
    None when none is named."""
    for word in argv:
        if word == "--":
            return None
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


#: commands after which the process ends at once (`entry`): they leave no
#: process, thread or file open behind them when `main` returns
QUICK_EXIT = ("simulate", "linearize")


def entry() -> None:
    """The `modesel` console command (and `python -m modesel`): a command of
    `modesel.forwarding.SERVED` handed to a running `modesel serve` where one
    is found (`forwarding.forward`), else `main`; then,
    after a command of QUICK_EXIT, the output flushed and the process ended
    at once (os._exit) with its exit code. Python's own shutdown, which
    finalises the modules and numba's and LLVM's objects one by one, took
    0.15 s of a 1.2-s `modesel simulate` (docs/benchmarks.md). Other
    commands end as Python ends them (their workers, storages and
    temporary folders are finalised at shutdown)."""
    argv = sys.argv[1:]
    command = command_of(argv)
    code = None
    if command in QUICK_EXIT:
        from modesel import forwarding
        if command in forwarding.SERVED:     # a running `modesel serve` takes it
            code = forwarding.forward(argv)
    if code is None:
        code = main(argv)
    if command in QUICK_EXIT:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):      # a closed pipe: nothing more can be said
                pass
        os._exit(code)
    raise SystemExit(code)


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
        module_name = COMMAND_MODULES.get(name, f"modesel.commands.{name}")
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:  # command not built yet in this checkout
            if exc.name != module_name:
                raise
            continue
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    # The engine's matrices have a few hundred rows at most: OpenBLAS worker
    # threads only add synchronisation (measured 40-100 ms instead of 0.3 ms per
    # right-hand side on a loaded machine, docs/benchmarks.md). One thread for
    # the whole command (linearize, workers, reports) unless the user set it;
    # effective only before numpy is first imported, as here.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    parser = build_parser(command_of(argv))
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    previous = _handle_signals()
    previous_hook = sys.unraisablehook
    sys.unraisablehook = functools.partial(_unraisable, previous=previous_hook)
    RECEIVED.clear()
    _RUNNING.set()
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
        return stopped("SIGTERM" if isinstance(exc, Terminated) else "SIGINT")
    except Exception:
        if args.debug or not RECEIVED:
            raise
        return stopped(RECEIVED[0])    # an error that follows a signal (module doc): the signal is the cause
    finally:
        _RUNNING.clear()
        sys.unraisablehook = previous_hook
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def stopped(name: str) -> int:
    """Print the one line of a command stopped by signal `name` ("SIGINT",
    "SIGTERM") and return its exit code (`Interrupted`'s)."""
    exc = Interrupted(f"interrupted ({name})", signal_name=name)
    print(f"modesel: {exc}", file=sys.stderr)
    return exc.exit_code


def _handle_signals() -> dict:
    """`_on_signal` for SIGINT and SIGTERM in the main thread; returns the
    previous handlers (none when not in the main thread, where signals cannot
    be set, or where SIGINT is ignored, as in a search's worker)."""
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        try:
            if signal.getsignal(signum) is not signal.SIG_IGN:
                previous[signum] = signal.signal(signum, _on_signal)
        except ValueError:
            break
    return previous


if __name__ == "__main__":
    raise SystemExit(main())
