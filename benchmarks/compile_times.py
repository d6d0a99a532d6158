"""Where a first run's compile time goes: numba's compile events of one
`modesel simulate SCENE --tmax 1` in this process, with an empty numba cache
(a fresh `NUMBA_CACHE_DIR`) and without the first run's child process (so
every function compiles here, one after the other), per jitted function:
inclusive seconds and exclusive seconds (without the functions it compiled
on the way). A function's exclusive time includes optimising and emitting
again the code of every separately compiled function it calls, which numba
links into its library. cfuncs raise no compile event: their time shows in
the total only.

    python3 benchmarks/compile_times.py [SCENE] [--top 30]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SCENE = os.path.join(REPO, "studies", "data", "openfast", "steady_08", "steady_08.fst")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", nargs="?", default=SCENE)
    p.add_argument("--top", type=int, default=30)
    a = p.parse_args(argv)
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="compile-times-")
    sys.path.insert(0, REPO)
    from numba.core import event

    import modesel.simulation.first_run as first_run
    first_run.compile_in_parallel = lambda built: False     # everything in this process
    stack, rows = [], []

    class Listener(event.Listener):
        def on_start(self, ev):
            fn = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
            name = f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', '?')}"
            stack.append([name, time.perf_counter(), 0.0])

        def on_end(self, ev):
            name, t0, inner = stack.pop()
            dt = time.perf_counter() - t0
            rows.append((name, dt, dt - inner))
            if stack:
                stack[-1][2] += dt

    event.register("numba:compile", Listener())
    from modesel.cli import main as cli
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        try:
            cli(["simulate", a.scene, "--tmax", "1", "--out", os.path.join(tmp, "out.csv")])
        except SystemExit:
            pass
        total = time.perf_counter() - t0
    per = {}
    for name, inc, exc in rows:
        c = per.setdefault(name, [0, 0.0, 0.0])
        c[0] += 1
        c[1] += inc
        c[2] += exc
    print(f"{'function':<56} {'compiles':>8} {'incl [s]':>9} {'excl [s]':>9}")
    for name, (count, inc, exc) in sorted(per.items(), key=lambda kv: -kv[1][2])[:a.top]:
        print(f"{name:<56} {count:>8d} {inc:>9.2f} {exc:>9.2f}")
    print(f"whole command: {total:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
