"""The client side of `modesel serve` (modesel.server): find a running
server and hand it a command (`forward`).

`cli.entry` calls `forward` for the commands of `SERVED`, before it imports
anything else: when a socket is found at `socket_path()` (the environment
variable MODESEL_SERVER names it; `off` turns forwarding off), it sends its
arguments, working folder, environment, umask and its standard input,
output and error (their file descriptors, SCM_RIGHTS) to the server and
waits for the exit code, passing Ctrl-C and SIGTERM on. Without a server,
or where the server refuses the request (`code_stamp` differs: another
modesel), the caller runs the command itself. Standard library only.
"""
from __future__ import annotations

import hashlib
import os
import stat
import sys
from pathlib import Path

#: commands a client hands to a running server
SERVED = ("simulate", "linearize")
#: the environment variable naming the socket ("off": never forward)
ENV = "MODESEL_SERVER"

_ROOT = Path(__file__).resolve().parent
#: bytes of a message's length (big-endian) and of an exit code
HEADER = 4


def socket_path() -> Path | None:
    """The server's socket: MODESEL_SERVER when set (None for "off" or an
    empty value), else `modesel/server.sock` in XDG_RUNTIME_DIR, or in
    `/tmp/modesel-<uid>` where that is not set."""
    named = os.environ.get(ENV)
    if named is not None:
        return None if named.strip().lower() in ("", "off", "0", "no") else Path(named)
    base = os.environ.get("XDG_RUNTIME_DIR")
    folder = Path(base) / "modesel" if base else Path(f"/tmp/modesel-{os.getuid()}")
    return folder / "server.sock"


def code_stamp() -> str:
    """sha1 of what a served command's result depends on besides its
    request (module doc): the interpreter, modesel's folder, each source
    file's path, mtime and size, the NUMBA_* variables. Stats only (~1 ms)."""
    h = hashlib.sha1()
    h.update(f"{sys.executable}\0{_ROOT}\0".encode())
    for path in sorted(_ROOT.rglob("*.py")):
        st = path.stat()
        h.update(f"{path.relative_to(_ROOT).as_posix()}\0{st.st_mtime_ns}\0{st.st_size}\0".encode())
    for key in sorted(k for k in os.environ if k.startswith("NUMBA_")):
        h.update(f"{key}={os.environ[key]}\0".encode())
    return h.hexdigest()


def forward(argv: list) -> int | None:
    """Run `argv` (a `SERVED` command) in a running server: its exit code,
    or None when no server takes it (none found, another user's socket, a
    refused stamp, a standard stream closed): the caller then runs it."""
    path = socket_path()
    if path is None:
        return None
    try:
        st = os.stat(path)
    except OSError:
        return None
    if not stat.S_ISSOCK(st.st_mode) or st.st_uid != os.getuid():
        return None
    import json       # here: a command with no server to find imports neither (about 7 ms)
    import socket
    try:
        for fd in (0, 1, 2):
            os.fstat(fd)
    except OSError:
        return None
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    received = []                       # signals while the request is on its way
    previous = _pass_signals_on(sock, received)
    try:
        sock.connect(str(path))
        umask = os.umask(0)
        os.umask(umask)
        body = json.dumps({"stamp": code_stamp(), "argv": list(argv), "cwd": os.getcwd(),
                           "env": dict(os.environ), "umask": umask}).encode()
        socket.send_fds(sock, [len(body).to_bytes(HEADER, "big")], [0, 1, 2])
        sock.sendall(body)
        taken = recv_exact(sock, 1) == b"A"         # else refused (another modesel) or no answer
    except OSError:
        taken = False
    if not taken:
        sock.close()
        _restore(previous)
        if received:        # Ctrl-C / SIGTERM before any command ran: stop here, as the command would
            print(f"modesel: interrupted ({received[0]})", file=sys.stderr)
            return 143 if received[0] == "SIGTERM" else 130
        return None
    try:
        reply = recv_exact(sock, 1 + HEADER)
    except OSError:
        reply = b""
    finally:
        sock.close()
        _restore(previous)
    if len(reply) == 1 + HEADER and reply[:1] == b"X":
        return int.from_bytes(reply[1:], "big", signed=True)
    print("modesel: error: the server's process for this command ended without an exit code "
          "(see the terminal of `modesel serve`)", file=sys.stderr)
    return 1


def _pass_signals_on(sock, received: list) -> dict:
    """SIGINT and SIGTERM sent on to the command's process through `sock`
    (noted in `received`), except where ignored (a background job), as the
    command by itself would; returns the previous handlers."""
    import signal

    def pass_on(signum, frame):
        name = "SIGTERM" if signum == signal.SIGTERM else "SIGINT"
        received.append(name)
        try:
            sock.send(b"T" if name == "SIGTERM" else b"I")
        except OSError:
            pass
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(signum) is not signal.SIG_IGN:
            previous[signum] = signal.signal(signum, pass_on)
    return previous


def _restore(previous: dict) -> None:
    import signal
    for signum, handler in previous.items():
        signal.signal(signum, handler)


def recv_exact(sock, n: int) -> bytes:
    """`n` bytes from `sock`, fewer only where it closed first."""
    parts, got = [], 0
    while got < n:
        part = sock.recv(n - got)
        if not part:
            break
        parts.append(part)
        got += len(part)
    return b"".join(parts)
