"""A compiled integration loop run in a thread that the calling thread
watches: `run_watched`.

The loops (`kernel.runge_kutta`, `implicit.radau5`) run without the GIL and
take a `control` array (`kernel.STOP_REQUEST`, `kernel.TIME_REACHED`). The
caller's thread waits for the loop's thread in slices of `POLL_S` seconds,
and between them:

- reports the time reached to a `progress(t, tmax)` hook (the progress line
  of a long `modesel simulate`, `simulation.progress.SimulationProgress`);
- lets Python run its signal handlers: Ctrl-C (KeyboardInterrupt) or the
  CLI's SIGTERM exception in the caller's thread sets the stop request, the
  loop returns after the step it is on (milliseconds), and the exception
  goes on. Called in a loop directly, a signal waited until the whole
  integration had ended (3000 s of steady_08: 11 s after Ctrl-C).
"""
from __future__ import annotations

import threading

import numpy as np

#: seconds between two looks of the caller's thread at the loop (progress, signals)
POLL_S = 0.25


def run_watched(loop, args, tmax: float, progress=None, poll_s: float = POLL_S):
    """loop(*args, control), run in a thread; returns its result. progress:
    None or progress(t [s], tmax [s]), called about every poll_s seconds
    while the loop runs. An exception in the caller's thread while it waits
    (Ctrl-C) stops the loop after its current step and is raised again once
    the loop's thread has ended; an exception in the loop is raised here."""
    control = np.zeros(2)
    box = {}

    def target():
        try:
            box["result"] = loop(*args, control)
        except BaseException as exc:        # raised again in the caller's thread
            box["error"] = exc

    thread = threading.Thread(target=target, name="modesel-integration", daemon=True)
    thread.start()
    try:
        while True:
            thread.join(poll_s)
            if not thread.is_alive():
                break
            if progress is not None:
                progress(float(control[1]), float(tmax))
    except BaseException:
        control[0] = 1.0
        thread.join()
        raise
    if "error" in box:
        raise box["error"]
    return box["result"]
