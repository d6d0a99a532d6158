"""First run after install: wall and CPU time of `modesel simulate SCENE --tmax 1`
with an empty numba cache (a fresh `NUMBA_CACHE_DIR` per run, so numba
compiles the whole engine), then the same command once more with that cache
(warm), for each scene. Issue 12's target: the compile step at most 30 s on
2 cores.

Run: python3 benchmarks/bench_first_run.py [--repeat 2] [SCENE ...]
     (default scenes: the OpenFAST case steady_08 with BEM, and the 3-DOF
     land model without effects; the second scene of a run after the first
     is also timed against the first's cache: one compile serves both)

CPU is the children's user + system time (the command and the process that
compiles the loads beside it). Timings on a machine shared with other jobs
vary; the script prints the load average before and after.
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCENES = [REPO / "studies" / "data" / "openfast" / "steady_08" / "steady_08.fst",
          REPO / "studies" / "scenes" / "paper_3dof_land.toml"]


def simulate(scene: Path, cache: str, out: str) -> tuple:
    """(wall [s], CPU [s]) of one `modesel simulate` with numba's cache in `cache`."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache,
               PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "modesel", "simulate", str(scene), "--tmax", "1", "--out", out],
                          env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"modesel simulate {scene} failed ({done.returncode}): {done.stderr.strip()[-800:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scenes", nargs="*", type=Path, default=SCENES, help="scenes (default: steady_08, paper_3dof_land)")
    p.add_argument("--repeat", type=int, default=2, help="cold runs per scene")
    a = p.parse_args()
    print(f"{os.cpu_count()} cores; load average {os.getloadavg()[0]:.1f} (1 min) before", flush=True)
    print(f"{'scene':<24} {'run':<28} {'wall [s]':>9} {'CPU [s]':>8}", flush=True)
    with tempfile.TemporaryDirectory(prefix="bench-first-run-") as tmp:
        out = os.path.join(tmp, "out.csv")
        for k in range(a.repeat):
            for i, scene in enumerate(a.scenes):
                cache = tempfile.mkdtemp(dir=tmp)
                wall, cpu = simulate(scene, cache, out)
                print(f"{scene.stem:<24} {'first run (empty cache)':<28} {wall:>9.1f} {cpu:>8.1f}", flush=True)
                wall, cpu = simulate(scene, cache, out)
                print(f"{scene.stem:<24} {'second run (warm cache)':<28} {wall:>9.1f} {cpu:>8.1f}", flush=True)
                other = a.scenes[(i + 1) % len(a.scenes)]
                if other != scene and k == 0:
                    wall, cpu = simulate(other, cache, out)
                    print(f"{other.stem:<24} {'after ' + scene.stem[:22]:<28} {wall:>9.1f} {cpu:>8.1f}", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} (1 min) after")


if __name__ == "__main__":
    main()
