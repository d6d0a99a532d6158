"""`modesel serve`: a warm modesel that runs `simulate` and `linearize` for
the commands typed while it runs.

A fresh `modesel simulate` pays numba's floor before it computes anything:
Python, numpy and numba imported, numba's target context set up, the
engine's compiled libraries loaded from numba's on-disk cache (about 0.5 s
of the 0.85 s a 20-s steady_08 takes, docs/benchmarks.md). The server pays
it once: it imports the engine and, for every scene it is asked to run,
loads that scene's compiled code (a run of one output step, its "warm-up",
after the scene's first request, or at start for --warm), then waits on a
Unix socket.

A command finds it through `modesel.forwarding` (the client side, called by
`cli.entry`) and hands over its arguments, folder, environment, umask and
standard streams. The server forks a child of its warm self for each
request; the child takes the client's descriptors, folder and environment,
runs the command as the client would have run it (`cli.main`), writing
straight into the client's terminal, pipes or files, and sends back the exit
code, which the client exits with. Forwarding never changes what a command
computes, only where (tests/test_server.py compares the CSVs byte for byte).

This module sits above `cli` (its children run `cli.main`); `cli` finds the
`serve` command here by name (`cli.COMMAND_MODULES`) and imports only
`modesel.forwarding` itself.

Safety:
- the socket lies in a folder only its user may enter (mode 0700), the
  client connects only to a socket its own user owns, and the server serves
  only its own user (SO_PEERCRED);
- the server refuses a request from another modesel: the stamp
  (`forwarding.code_stamp`) covers the interpreter, modesel's folder, the mtime and
  size of every source file of modesel, and the NUMBA_* environment
  variables (read by numba when it is imported); an edited source makes the
  next request run locally;
- no process outlives the command: Ctrl-C or SIGTERM given to the client is
  passed on to the child, which stops as the command by itself does (exit
  130 or 143; a compiled integration after its current step,
  `multibody.watch`);
  a client that dies (SIGKILL, a closed terminal) closes the socket, and its
  child gets SIGTERM and ends at most `ORPHAN_GRACE_S` later; the server
  stops its children and waits for them when it stops (Ctrl-C, SIGTERM, or
  `idle_exit_s` without requests).
"""
from __future__ import annotations

import argparse
import contextlib
import gc
import io
import json
import math
import os
import select
import signal
import socket
import struct
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

from modesel import cli
from modesel.errors import ModeselError
from modesel.forwarding import ENV, HEADER, SERVED, code_stamp, recv_exact, socket_path
from modesel.multibody.blas import keep_one_thread

#: the simulated time [s] and output step of a warm-up run
WARM_TMAX_S = 0.05
#: seconds an orphaned child (its client gone) has to stop after SIGTERM
ORPHAN_GRACE_S = 5.0

# --- the child (one request) ---------------------------------------------------------------------

def run_request(conn, fds: list, request: dict) -> None:
    """In the forked child: take the client's descriptors, folder,
    environment and umask, run the command, send the exit code, end the
    process (never returns)."""
    code = 1
    done = threading.Event()

    def stop(signum, frame):            # until the command's own handlers (cli.main) are set
        raise cli.Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
    try:
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, stop)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
        for target, fd in zip((0, 1, 2), fds):
            os.dup2(fd, target)
            os.close(fd)
        sys.stdout = os.fdopen(1, "w", buffering=1 if os.isatty(1) else -1, closefd=False)
        sys.stderr = os.fdopen(2, "w", buffering=1, closefd=False, errors="backslashreplace")
        os.chdir(request["cwd"])
        os.environ.clear()
        os.environ.update(request["env"])
        os.umask(int(request["umask"]))
        threading.Thread(target=_watch_client, args=(conn, done), daemon=True).start()
        code = cli.main(list(request["argv"]))
    except KeyboardInterrupt as exc:        # before or after the command ran
        code = cli.stopped("SIGTERM" if isinstance(exc, cli.Terminated) else "SIGINT")
    except BaseException:       # noqa: BLE001 - whatever happens, the client gets an exit code
        traceback.print_exc()
    finally:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})   # the reply goes out whole
        done.set()
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        try:
            conn.sendall(b"X" + int(code).to_bytes(HEADER, "big", signed=True))
        except OSError:
            pass
        os._exit(int(code) & 0xFF)


def _watch_client(conn, done) -> None:
    """The child's thread on the client's socket: a signal the client passes
    on is sent to this process; the client gone (EOF) stops the command
    (module doc)."""
    while True:
        try:
            data = conn.recv(1)
        except OSError:
            data = b""
        if done.is_set():
            return
        if data in (b"I", b"T"):
            os.kill(os.getpid(), signal.SIGINT if data == b"I" else signal.SIGTERM)
            continue
        os.kill(os.getpid(), signal.SIGTERM)          # the client is gone
        time.sleep(ORPHAN_GRACE_S)
        os._exit(143)


# --- the server --------------------------------------------------------------------------------

class Server:
    """`modesel serve`: listen on `path`, fork a warm child per request,
    warm itself on each new scene (module doc). `say` prints its log lines."""

    def __init__(self, path: Path, *, warm: list = (), idle_exit_s: float = 3600.0, say=print):
        self.path = Path(path)
        self.idle_exit_s = float(idle_exit_s)
        self.say = say
        self.stamp = code_stamp()
        self.children: dict = {}        # pid -> (request text, start time, argv, folder)
        self.warmed: set = set()
        self.pending_warm = [_warm_simulation([os.path.abspath(s)]) for s in warm]
        self.listener = None
        self.pid = os.getpid()

    # listening

    def open(self) -> None:
        """Bind the socket (its folder made 0700); a live server already
        there is a ModeselError, a stale socket file is replaced."""
        if len(os.fsencode(self.path)) > 100:
            raise ModeselError("a Unix socket's path must be at most 100 bytes long", file=str(self.path),
                               field="--socket")
        self.path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        if self.path.parent.stat().st_uid != os.getuid():
            raise ModeselError("the socket's folder belongs to another user", file=str(self.path.parent),
                               field="--socket")
        if os.path.lexists(self.path):
            probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                probe.connect(str(self.path))
                raise ModeselError("a server already listens on this socket (stop it first)",
                                   file=str(self.path), field="--socket")
            except OSError:
                os.unlink(self.path)          # nobody listens: a socket file left by a killed server
            finally:
                probe.close()
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old = os.umask(0o077)
        try:
            self.listener.bind(str(self.path))
        except OSError as exc:
            raise ModeselError(f"cannot listen here: {exc.strerror}", file=str(self.path),
                               field="--socket") from None
        finally:
            os.umask(old)
        self.listener.listen(64)

    def close(self) -> None:
        """Remove the socket and stop the children: SIGTERM, and wait for
        them (a command in a compiled integration stops after its current
        step, as it would by itself); Ctrl-C or SIGTERM again kills them (SIGKILL).
        Only in the server itself, not in a child."""
        if os.getpid() != self.pid:
            return
        if self.listener is not None:
            self.listener.close()
            self.listener = None
            try:
                os.unlink(self.path)
            except OSError:
                pass
        self.reap()                     # those that ended already (not to be announced as running)
        for pid in list(self.children):
            _kill(pid, signal.SIGTERM)
        try:
            if self.children:
                self.say(f"modesel serve: stopping {len(self.children)} running command(s) (Ctrl-C again "
                         f"kills them)")
            while self.children:
                self.reap()
                time.sleep(0.02)
        except KeyboardInterrupt:
            for pid in list(self.children):
                _kill(pid, signal.SIGKILL)
            while self.children:
                self.reap(block=True)
            raise

    def serve_forever(self) -> None:
        """Warm up, then take requests until stopped or idle for idle_exit_s."""
        keep_one_thread()    # even where the user set OPENBLAS_NUM_THREADS: no BLAS pool in the children
        self.warm_up()
        self.say(f"modesel serve: listening on {self.path} (Ctrl-C stops it; it stops by itself after "
                 f"{self.idle_exit_s:g} s without requests)")
        last = time.monotonic()
        while True:
            ready, _, _ = select.select([self.listener], [], [], 0.02 if self.children else 0.5)
            if ready:
                self.accept()
                last = time.monotonic()
            self.reap()
            if self.children:
                last = time.monotonic()
            else:
                self.warm_up()
                if self.idle_exit_s > 0 and time.monotonic() - last > self.idle_exit_s:
                    self.say(f"modesel serve: no request for {self.idle_exit_s:g} s; stopped")
                    return

    # requests

    def accept(self) -> None:
        conn, _ = self.listener.accept()
        fds = []
        try:
            conn.settimeout(5.0)
            pid, uid, gid = struct.unpack("3i", conn.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED,
                                                                struct.calcsize("3i")))
            if uid != os.getuid():
                return
            head, fds, _, _ = socket.recv_fds(conn, HEADER, 3)
            request = json.loads(recv_exact(conn, int.from_bytes(head, "big")))
            text = _printable(" ".join(str(a) for a in request["argv"]))
            if request.get("stamp") != self.stamp or len(fds) != 3:
                conn.sendall(b"R")
                self.say(f"refused (another modesel: its sources, interpreter or NUMBA_* differ from this "
                         f"server's; it runs by itself): {text}")
                return
            record = (text, time.monotonic(), request["argv"], request["cwd"])
            conn.settimeout(None)
            self._fork(conn, fds, request, record)
        except (OSError, ValueError, KeyError, TypeError):
            return                 # a broken request: the client runs the command itself
        finally:
            for fd in fds:
                os.close(fd)
            conn.close()

    def _fork(self, conn, fds, request, record) -> None:
        """Take the request (the answer "A") and fork its child; `record` is
        kept in `children` under its pid before a signal to the server is let
        through: a SIGTERM that lands here stops this child with the others,
        or, before the answer, leaves the client to run the command itself."""
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        gc.freeze()                # the warm objects stay shared with the child (copy-on-write)
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        try:
            conn.sendall(b"A")
            pid = os.fork()
            if pid == 0:
                try:
                    self.listener.close()
                    run_request(conn, fds, request)        # never returns
                finally:
                    os._exit(1)
            self.children[pid] = record
        finally:                # in the server only: the child ends in os._exit
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)

    def reap(self, block: bool = False) -> None:
        """Collect ended children, log them, queue their scene's warm-up."""
        for pid in list(self.children):
            try:
                done, status = os.waitpid(pid, 0 if block else os.WNOHANG)
            except ChildProcessError:
                done, status = pid, 0
            if not done:
                continue
            text, start, argv, cwd = self.children.pop(pid)
            code = os.waitstatus_to_exitcode(status)
            self.say(f"{text}: exit {code} in {time.monotonic() - start:.3f} s")
            if code == 0:            # its warm-up, parsed here: off the path of a request
                self.pending_warm.append(self._warm_argv(argv, cwd))

    # warm-up

    def _warm_argv(self, argv: list, cwd: str):
        """The command that loads what `argv` runs (one output step of a
        simulation of its scene, into a temporary file; the same linearisation
        printed to nowhere), with paths made absolute; None where there is
        none to run (a parse error, another command)."""
        try:
            command = cli.command_of(argv)
            if command not in SERVED:
                return None
            args = cli.build_parser(command).parse_args(argv)
        except SystemExit:
            return None
        absolute = [os.path.join(cwd, args.scene)]
        if args.modeset:
            absolute += ["--modeset", os.path.join(cwd, args.modeset)]
        if command == "simulate":
            extra = ["--no-stability-check"] if args.no_stability_check else []
            return _warm_simulation(absolute + extra)
        extra = (["--rpm", args.rpm] if args.rpm else []) + (["--no-aero"] if args.no_aero else [])
        return ["linearize", *absolute, *extra]

    def warm_up(self) -> None:
        """Run the queued warm-ups not run before, in this process (module
        doc); a failing one is said in one line and forgotten."""
        while self.pending_warm:
            argv = self.pending_warm.pop(0)
            if argv is None or tuple(argv) in self.warmed:
                continue
            self.warmed.add(tuple(argv))
            with tempfile.TemporaryDirectory() as folder:
                full = argv + ["--out", os.path.join(folder, "warm.csv")] if argv[0] == "simulate" else argv
                err = io.StringIO()
                with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                    code = cli.main(full)
            if code in (130, 143):        # the server was stopped during its warm-up
                raise cli.Terminated() if code == 143 else KeyboardInterrupt()
            if code:
                last = (err.getvalue().strip().splitlines() or ["?"])[-1]
                self.say(f"warm-up of {_printable(argv[1])} failed ({last}); its requests load it themselves")


def _warm_simulation(scene_args: list) -> list:
    """The warm-up of a simulation of `scene_args` (the scene and its
    options): one output step of WARM_TMAX_S (the output file is added by
    `Server.warm_up`)."""
    return ["simulate", *scene_args, "--tmax", f"{WARM_TMAX_S:g}", "--dt", f"{WARM_TMAX_S:g}"]


def _kill(pid: int, signum) -> None:
    try:
        os.kill(pid, signum)
    except ProcessLookupError:
        pass


def _printable(text: str) -> str:
    """`text` with control characters escaped, for the server's log."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


# --- the command ------------------------------------------------------------------------------

def register(subparsers):
    p = subparsers.add_parser("serve", help="keep a warm modesel for simulate and linearize",
                              description=COMMAND_DOC, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--socket", help="the Unix socket to listen on (default: see above)")
    p.add_argument("--warm", action="append", default=[], metavar="SCENE",
                   help="a scene to load before the first request (repeatable)")
    p.add_argument("--idle-exit", type=float, default=3600.0, metavar="S",
                   help="stop after S seconds without requests (default 3600; 0: never)")
    p.set_defaults(func=run)


COMMAND_DOC = """`modesel serve [--socket PATH] [--warm SCENE ...] [--idle-exit S]`

Keep a warm modesel that runs `modesel simulate` and `modesel linearize`
for the commands typed while it runs: they find it (at --socket, by default
$XDG_RUNTIME_DIR/modesel/server.sock or /tmp/modesel-<uid>/server.sock; the
environment variable MODESEL_SERVER names another socket, or `off`), hand
it their arguments and their terminal, and end with its exit code, without
paying numba's start (about 0.5 s) each time. The results are those of the
command run by itself. --warm loads a scene's compiled code before the
first request; a scene asked for is loaded after its first run. The server
logs one line per request; it stops on Ctrl-C or SIGTERM (stopping the
commands it runs) or after --idle-exit seconds without requests.
"""


def run(args) -> int:
    if not math.isfinite(args.idle_exit) or args.idle_exit < 0:
        raise ModeselError(f"must be a finite number of seconds >= 0, got {args.idle_exit:g}", field="--idle-exit")
    for scene in args.warm:
        if not Path(scene).is_file():
            raise ModeselError("not a file", file=scene, field="--warm")
    path = Path(args.socket) if args.socket else socket_path()
    if path is None:
        raise ModeselError(f"{ENV} is off: give --socket PATH", field="--socket")
    serving = Server(path, warm=args.warm, idle_exit_s=args.idle_exit, say=lambda text: print(text, flush=True))
    serving.open()
    try:
        serving.serve_forever()
    finally:
        serving.close()
    return 0
