"""Search throughput: trials per minute of `modesel run` on 2 cores for the
tower free-decay study and the full-turbine study, and the speed-up of
--n-jobs 2 over 1. Run: python benchmarks/bench_search.py [--turbine-trials N]

Each run uses a fresh output folder (no resume); the internal reference of
the turbine study is built once before timing (it is cached on disk)."""
from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import pandas as pd

from modesel.cli import main


def timed_run(study: str, n_trials: int, n_jobs: int, cache: Path | None = None) -> tuple[float, int]:
    out = Path(tempfile.mkdtemp(prefix="bench-search-"))
    try:
        args = ["run", study, "--out", str(out), "--n-trials", str(n_trials), "--n-jobs", str(n_jobs)]
        t0 = time.perf_counter()
        assert main(args) == 0
        wall = time.perf_counter() - t0
        n = len(pd.read_csv(out / "trials.csv"))
        return wall, n
    finally:
        shutil.rmtree(out, ignore_errors=True)


def main_bench():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--tower-trials", type=int, default=30)
    p.add_argument("--turbine-trials", type=int, default=8)
    a = p.parse_args()
    rows = []
    for study, n in (("studies/tower_free_decay.toml", a.tower_trials),
                     ("studies/turbine_steady_wind.toml", a.turbine_trials)):
        if "turbine" in study:      # build and cache the internal reference first
            timed_run(study, 1, 1)
        per = {}
        for jobs in (1, 2):
            wall, done = timed_run(study, n, jobs)
            per[jobs] = done / wall * 60.0
            rows.append((Path(study).stem, jobs, done, wall, per[jobs]))
        rows.append((Path(study).stem, "speed-up 2 vs 1", "", "", per[2] / per[1]))
    print(f"{'study':<22} {'n_jobs':>16} {'trials':>7} {'wall [s]':>9} {'trials/min':>11}")
    for r in rows:
        print(f"{r[0]:<22} {str(r[1]):>16} {str(r[2]):>7} "
              f"{(f'{r[3]:.1f}' if r[3] != '' else ''):>9} {r[4]:>11.2f}")


if __name__ == "__main__":
    main_bench()
