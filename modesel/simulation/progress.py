"""What a person sees while one simulation runs: a note and a live line
while the engine compiles on first use, and the progress line of a long
`modesel simulate`. The search's bar (`study.search.progress`) shows the
same compile note and line; this module imports neither optuna nor pandas.

- `SimulationProgress`: a one-line "simulated t of T s, 0.21x real time,
  ETA ..." on stderr, refreshed about once per wall second by the
  integrator's `progress` hook, shown once a run has taken more than
  `after_s` seconds (short runs print nothing).
- `compile_notice`: "compiling the engine (first run only, ~40 s)..." on a terminal when
  the numba cache of the engine's kernel holds no index file yet.
- `CompileProgress`: while numba compiles (cache misses only), one line on a
  terminal with the functions compiled so far, the one being compiled and
  the elapsed time; then how long it took.
"""
from __future__ import annotations

import sys
import time

from modesel.simulation.first_run import index_files

#: wall seconds between redraws of a progress line (the compile line here,
#: the search bar in `study.search.progress`) while work runs
REFRESH_S = 1.0
COMPILE_MESSAGE = "modesel: compiling the engine (first run only, ~40 s)..."
#: modules whose @njit(cache=True) functions are compiled on first use (the
#: kernel, by every simulation; the BEM functions compile only with aero, so
#: they cannot tell a warm engine of a scene without aero)
COMPILED_MODULES = ("modesel.multibody.kernel",)


def engine_is_cold() -> bool:
    """True when the engine's compiled kernel has no numba cache yet (the
    first simulation will compile it)."""
    try:
        return not all(index_files(m) for m in COMPILED_MODULES)
    except OSError:
        return False


def compile_notice(stream=None, quiet: bool = False) -> bool:
    """Print `COMPILE_MESSAGE` when the engine is cold; True if printed. On
    stderr only when it is a terminal (a person waiting), as the progress bar:
    scripts and logs read one line per error."""
    if quiet or not engine_is_cold():
        return False
    if stream is None:
        if not sys.stderr.isatty():
            return False
        stream = sys.stderr
    print(COMPILE_MESSAGE, file=stream, flush=True)
    return True


class CompileProgress:
    """Context manager around code that may compile the engine (the first run
    after install or after a source change). On a terminal (stderr) and not
    `quiet`, from numba's first compilation on (numba's "numba:compile" event,
    raised on cache misses only, so a warm run prints nothing):

        modesel: compiling the engine (first run only): 12 functions, 37 s [now: _aero]

    redrawn at every compiled function and once per second, then
    "modesel: engine compiled in 66 s (12 functions); later runs load it from numba's cache"."""

    def __init__(self, stream=None, quiet: bool = False, enabled: bool | None = None):
        self.stream = stream or sys.stderr
        self.enabled = (self.stream.isatty() if enabled is None else enabled) and not quiet
        self.count = 0
        self.current = ""
        self.start = None
        self._depth = 0
        self._listener = None
        self._stop = None

    def line(self, elapsed: float) -> str:
        now = f" [now: {self.current}]" if self.current else ""
        return (f"modesel: compiling the engine (first run only): {_functions(self.count)}, "
                f"{_duration(elapsed)}{now}")

    def _draw(self):
        with self._lock:
            if self.start is not None:
                print("\r" + self.line(time.perf_counter() - self.start) + "\x1b[K", end="", file=self.stream,
                      flush=True)

    def _started(self, name: str):
        if self.start is None:
            import threading
            self.start = time.perf_counter()
            self._stop = threading.Event()
            threading.Thread(target=self._tick, daemon=True).start()
        if self._depth == 0:
            self.current = name
        self._depth += 1
        self.count += 1
        self._draw()

    def _ended(self):
        self._depth = max(0, self._depth - 1)
        if self._depth == 0:
            self.current = ""

    def _tick(self):
        while not self._stop.wait(REFRESH_S):
            self._draw()

    def __enter__(self):
        import threading
        self._lock = threading.Lock()
        if self.enabled:
            from numba.core import event

            progress = self

            class Listener(event.Listener):
                def on_start(self, ev):
                    progress._started(ev.data["dispatcher"].py_func.__name__)

                def on_end(self, ev):
                    progress._ended()

            self._listener = Listener()
            event.register("numba:compile", self._listener)
        return self

    def __exit__(self, exc_type, *exc):
        if self._listener is not None:
            from numba.core import event
            event.unregister("numba:compile", self._listener)
        if self._stop is not None:
            self._stop.set()
            with self._lock:
                if exc_type is None:
                    took = _duration(time.perf_counter() - self.start)
                    print(f"\rmodesel: engine compiled in {took} ({_functions(self.count)}); later runs load it "
                          "from numba's cache\x1b[K", file=self.stream, flush=True)
                else:                  # an error or Ctrl-C: erase the line, the command's one line follows
                    print("\r\x1b[K", end="", file=self.stream, flush=True)
            self.start = None
        return False


def _functions(count: int) -> str:
    return f"{count} function" + ("" if count == 1 else "s")


def _duration(seconds: float) -> str:
    seconds = max(0.0, float(seconds))
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds // 60:.0f} min {seconds % 60:02.0f} s"
    return f"{seconds // 3600:.0f} h {seconds % 3600 // 60:02.0f} min"


def speed_text(simulated_s: float, wall_s: float) -> str:
    """Simulated seconds per wall second with two significant digits, e.g.
    '0.23x real time', '170x real time' (not '1.7e+02x')."""
    if wall_s <= 0:
        return "- x real time"
    rate = simulated_s / wall_s
    return f"{float(f'{rate:.2g}'):g}x real time" if rate < 1e6 else f"{rate:.2g}x real time"


class SimulationProgress:
    """`progress(t, tmax)` hook of a simulation: after `after_s` wall seconds,
    rewrites one stderr line at most once per `every_s` wall seconds:
    "simulated 4.3 of 20 s, 0.21x real time, ETA 1 min 15 s". The speed and
    ETA count from the hook's first call (the start of the integration, not
    the model set-up before it); `close` erases the line (the command's
    summary follows)."""

    def __init__(self, label: str = "", stream=None, after_s: float = 2.0, every_s: float = 1.0,
                 enabled: bool | None = None):
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.label = label
        self.after_s, self.every_s = after_s, every_s
        self.start = time.perf_counter()
        self.first = None           # wall clock at the first call (the integration starts at t = 0)
        self.last = -1e9
        self.shown = False

    def line(self, t: float, tmax: float, wall: float) -> str:
        """The line after `wall` seconds of integration that simulated `t` of `tmax` s."""
        rate = t / wall if wall > 0 else 0.0
        eta = _duration((tmax - t) / rate) if rate > 0 else "-"
        return (f"{self.label}simulated {t:.3g} of {tmax:.3g} s, {speed_text(t, wall)}, "
                f"ETA {eta}")

    def __call__(self, t: float, tmax: float) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if self.first is None:
            self.first = now
        if now - self.start < self.after_s or now - self.last < self.every_s:
            return
        self.last = now
        self.shown = True
        print("\r" + self.line(t, tmax, now - self.first) + "\x1b[K", end="", file=self.stream, flush=True)

    def close(self) -> None:
        if self.shown:
            print("\r\x1b[K", end="", file=self.stream, flush=True)
