"""User-facing errors.

Every problem a user can cause (a bad file, a bad field, a reference that
cannot be used, a simulation that diverges) is raised as a `ModeselError`.
The CLI prints it as one line naming the file and the field, and exits
with code 2; `--debug` shows the traceback.
"""
from __future__ import annotations

import difflib


class ModeselError(Exception):
    """A problem the user can fix, reported on one line.

    Parameters
    ----------
    message : what is wrong, e.g. "count must be >= 1, got 0".
    file : the file (or URL) the problem is in, if any.
    field : the field/key/channel the problem is in, if any.
    """

    exit_code = 2

    def __init__(self, message: str, *, file: str | None = None, field: str | None = None):
        super().__init__(message)
        self.message = message
        self.file = None if file is None else str(file)
        self.field = field

    def __str__(self) -> str:
        where = ": ".join(p for p in (self.file, self.field) if p)
        text = f"{where}: {self.message}" if where else self.message
        return " ".join(text.split())  # always one line


class SimulationDiverged(ModeselError):
    """A simulation blew up (NaN, state beyond bounds, step-size collapse).

    `reason` says what was detected and `time` (s) when it happened.
    """

    def __init__(self, reason: str, time: float, *, file: str | None = None):
        super().__init__(f"simulation diverged at t={time:.4g} s: {reason}", file=file)
        self.reason = reason
        self.time = float(time)


class PhysicallyUnstable(SimulationDiverged):
    """The configuration is statically unstable, found before any time step:
    an elastic coordinate has a negative effective stiffness (e.g. a tower-top
    mass beyond the buckling load), seen by linearising at the initial state.
    A simulation of it would diverge, so it is a `SimulationDiverged` at t = 0
    (a search marks the trial failed with this reason).

    `coordinate` names the dominant coordinate of the unstable mode and
    `growth` (1/s) is the real positive eigenvalue of the first-order system.
    """

    def __init__(self, coordinate: str, growth: float, *, file: str | None = None, detail: str = ""):
        reason = (f"physically unstable configuration (refused before simulating): the mode "
                  f"dominated by {coordinate} has a negative effective stiffness (grows as "
                  f"exp({growth:.3g} t), t in s)" + (f"; {detail}" if detail else ""))
        super().__init__(reason, 0.0, file=file)
        self.message = reason
        self.coordinate = coordinate
        self.growth = float(growth)


class Interrupted(ModeselError):
    """The user stopped a command (SIGINT / Ctrl-C, or SIGTERM); what was
    finished is kept. Exit code 130 (SIGINT) or 143 (SIGTERM)."""

    def __init__(self, message: str = "interrupted", *, signal_name: str = "SIGINT"):
        super().__init__(message)
        self.exit_code = 143 if signal_name == "SIGTERM" else 130


def did_you_mean(name: str, choices) -> str:
    """Return ' (did you mean X?)' when a close match exists, else ''."""
    close = difflib.get_close_matches(str(name), [str(c) for c in choices], n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def unknown_name(kind: str, name: str, choices, *, file=None, field=None) -> ModeselError:
    """Error for an unknown name, listing the valid ones."""
    choices = sorted(str(c) for c in choices)
    return ModeselError(
        f"unknown {kind} '{name}'{did_you_mean(name, choices)}; valid: {', '.join(choices)}",
        file=file, field=field)
