"""Who runs a trial: each trial records its process as `owner`
('host:pid:start:run', unique even after pid reuse), so that a rerun can tell
a dead process's trial from a live one's (`storage.dead_running_trials`,
`claims`)."""
from __future__ import annotations

import os
import socket
from pathlib import Path

OWNER = "owner"
STALE_UNOWNED_S = 30.0     # a trial names its owner within milliseconds of its creation


def _stat(pid: int) -> tuple:
    """(state letter, start time in clock ticks since boot) of process `pid`
    from /proc, or (None, None) when unknown."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None, None
    return fields[0], fields[19]


def _start_time(pid: int) -> str | None:
    return _stat(pid)[1]


def process_owner(pid: int | None = None, run: str = "") -> str:
    """'host:pid:start:run' naming this process (or `pid`) uniquely, even after
    pid reuse; `run` tells apart several searches made by one process."""
    pid = os.getpid() if pid is None else pid
    return f"{socket.gethostname()}:{pid}:{_start_time(pid) or '?'}:{run}"


def owner_alive(owner: str) -> bool | None:
    """Whether the process named by `owner` runs: True/False on this host,
    None (unknown) for another host."""
    try:
        host, pid, start, _ = str(owner).rsplit(":", 3)
        pid = int(pid)
    except ValueError:
        return None
    if host != socket.gethostname():
        return None
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    state, now = _stat(pid)
    if state in ("Z", "X"):                 # killed, not yet reaped by its parent
        return False
    return now is None or start == "?" or now == start
