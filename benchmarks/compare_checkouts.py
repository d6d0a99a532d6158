"""Whole-process `modesel simulate` in two or more checkouts, interleaved:
wall and CPU time (user + system) of each run, best and median per checkout.

For a before/after figure on a machine whose speed drifts: the runs of the
checkouts alternate, so a drift weighs on each alike. Each checkout runs its
own modesel (`python3 -m modesel` with the checkout as working folder) on
the same case, once untimed first (numba's cache and Python's bytecode warm;
PYTHONDONTWRITEBYTECODE is dropped for these runs).

    git worktree add /tmp/before <commit>
    python3 benchmarks/compare_checkouts.py /tmp/before . [--runs 10] [--tmax 20] [--case CASE]
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CASE = Path(__file__).resolve().parents[1] / "studies/data/openfast/steady_08/steady_08.fst"


def run(checkout: Path, case: Path, tmax: float, out: Path) -> tuple:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "modesel", "simulate", str(case), "--tmax", f"{tmax:g}",
                           "--out", str(out)], cwd=checkout, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        raise SystemExit(f"{checkout}: {done.stderr.strip()}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("checkouts", nargs="+", type=Path)
    p.add_argument("--runs", type=int, default=10)
    p.add_argument("--tmax", type=float, default=20.0, help="simulated time [s]")
    p.add_argument("--case", type=Path, default=CASE)
    a = p.parse_args(argv)
    case = a.case.resolve()
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "out.csv"
        for c in a.checkouts:
            run(c, case, 1.0, out)
        times = {c: [] for c in a.checkouts}
        for _ in range(a.runs):
            for c in a.checkouts:
                times[c].append(run(c, case, a.tmax, out))
    print(f"{case.name}, {a.tmax:g} s simulated, {a.runs} runs each, interleaved:")
    for c, v in times.items():
        wall, cpu = [w for w, _ in v], [u for _, u in v]
        print(f"  {str(c):<24} wall best {min(wall):.3f} s, median {statistics.median(wall):.3f} s; "
              f"CPU best {min(cpu):.3f} s, median {statistics.median(cpu):.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
