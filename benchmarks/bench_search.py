"""Search throughput: trials per minute of `modesel run --n-jobs J` for
J = 1..N (N = the cores of this machine, `os.cpu_count()`) on the tower
free-decay study and the full-turbine study, and the speed-up over J = 1;
then two `modesel worker` processes (one process each) on one study in a
throwaway PostgreSQL server against one worker, for each study (skipped,
with the reason, when PostgreSQL or psycopg2 is missing).

Run: python3 benchmarks/bench_search.py [--tower-sets 60] [--turbine-sets 8]
     [--max-jobs N | --jobs 1,2,4,8,16] [--skip-tower] [--skip-turbine] [--skip-postgres]

On a many-core machine, --jobs names the points of the curve (each run
then needs at least as many sets as jobs, or some workers idle).

Each run is the real command in a fresh process and a fresh output folder
(no resume), with ``[budget] stop_when_met = false`` (a copy of the study
file beside it) so that every run does its whole budget. Two rates per run:

- search: trials (repeats included) and distinct sets simulated per minute
  between the first trial's start and the last trial's end, from the
  storage's own timestamps: the throughput the issue asks to scale;
- whole: sets per minute of the whole command (imports, loading the decks
  and the reference, results and report written), what a user waits for.

The turbine study's internal reference is built once before timing and
copied into each output folder (it is cached there), so no timed run
rebuilds it. Timings on a machine shared with other jobs vary; the script
prints the load average before and after, and two ceilings of the speed-up
at the largest job count: a pure-Python loop (`machine_ceiling`) and, before
and after each study's runs, the study's own scene simulated in that many
processes at once (`simulation_ceiling`), which also feels the processes'
use of the shared caches and memory.
"""
from __future__ import annotations

import argparse
import contextlib
import glob
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))                   # this checkout's modesel, installed or not
STUDIES = {"tower": REPO / "studies" / "tower_free_decay.toml",
           "turbine": REPO / "studies" / "turbine_steady_wind.toml"}


@contextlib.contextmanager
def full_budget_copy(study: Path):
    """A copy of `study` beside it (relative paths still resolve) with
    stop_when_met = false; removed afterwards."""
    text = study.read_text()
    if "stop_when_met = true" in text:
        text = text.replace("stop_when_met = true", "stop_when_met = false")
    copy = study.with_name(f".bench-{os.getpid()}-{study.name}")
    copy.write_text(text)
    try:
        yield copy
    finally:
        copy.unlink(missing_ok=True)


def modesel(*args, cwd=None) -> float:
    """Run `python -m modesel ARGS` quietly; returns its wall time [s]."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "modesel", *args, "--quiet"], cwd=cwd, env=env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"modesel {' '.join(args)} failed ({done.returncode}): {done.stderr.strip()[-800:]}")
    return wall


def search_rates(storage, name: str) -> dict:
    """Trials, sets simulated and the search span [s] of study `name` in
    `storage` (a journal path or a SQLAlchemy URL), from trial timestamps."""
    import optuna

    from modesel.study.search import open_storage
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    trials = optuna.load_study(study_name=name, storage=open_storage(str(storage))).get_trials(deepcopy=False)
    done = [t for t in trials if t.datetime_start is not None and t.datetime_complete is not None]
    span = (max(t.datetime_complete for t in done) - min(t.datetime_start for t in done)).total_seconds()
    sets = sum(1 for t in done if "modeset_json" in t.user_attrs and "duplicate_of" not in t.user_attrs)
    return {"trials": len(done), "sets": sets, "span": span}


def bench_jobs(label: str, study: Path, n_sets: int, jobs_list: list) -> list:
    rows = []
    with full_budget_copy(study) as copy, tempfile.TemporaryDirectory(prefix="bench-search-") as tmp:
        warm = Path(tmp) / "warm"              # compile, and build the internal reference once
        modesel("run", str(copy), "--out", str(warm), "--n-trials", "1", "--n-jobs", "1")
        for jobs in jobs_list:
            out = Path(tmp) / f"jobs{jobs}"
            if (warm / "reference").is_dir():
                shutil.copytree(warm / "reference", out / "reference")
            wall = modesel("run", str(copy), "--out", str(out), "--n-trials", str(n_sets),
                           "--n-jobs", str(jobs))
            r = search_rates(out / "study.journal", study_name(study))
            rows.append((label, f"--n-jobs {jobs}", r, wall))
            print(f"  {label} --n-jobs {jobs}: {r['sets']} sets, search {r['span']:.1f} s, whole {wall:.1f} s",
                  flush=True)
    return rows


def study_name(study: Path) -> str:
    import tomllib
    return tomllib.loads(study.read_text())["study"]["name"]


# --------------------------------------------------------------------------- PostgreSQL

def _pg_bin(name: str):
    return shutil.which(name) or next(iter(sorted(glob.glob(f"/usr/lib/postgresql/*/bin/{name}"))[::-1]), None)


@contextlib.contextmanager
def throwaway_postgres():
    """Yield a function db(name) -> URL of a new database in a throwaway
    cluster on loopback (as tests/test_postgres_workers.py starts one), or
    raise RuntimeError saying why there is none."""
    import importlib.util
    import pwd
    initdb, pg_ctl = _pg_bin("initdb"), _pg_bin("pg_ctl")
    if not (initdb and pg_ctl):
        raise RuntimeError("PostgreSQL (initdb, pg_ctl) is not installed; .ci/run installs it")
    if importlib.util.find_spec("psycopg2") is None:
        raise RuntimeError("psycopg2 is not installed")
    import psycopg2
    root = tempfile.mkdtemp(prefix="modesel-bench-pg-")
    data, sock = os.path.join(root, "pgdata"), os.path.join(root, "sock")
    os.mkdir(data)
    os.mkdir(sock)
    prefix = []
    if os.geteuid() == 0:                       # the server refuses to run as root
        try:
            uid = pwd.getpwnam("postgres").pw_uid
            user = "postgres"
        except KeyError:
            uid, user = pwd.getpwnam("nobody").pw_uid, "nobody"
        for p in (root, data, sock):
            os.chown(p, uid, -1)
        prefix = ["runuser", "-u", user, "--"]
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    subprocess.run(prefix + [initdb, "-D", data, "-A", "trust", "-U", "modesel"], check=True, capture_output=True)
    subprocess.run(prefix + [pg_ctl, "-D", data, "-w", "-l", os.path.join(root, "pg.log"), "-o",
                             f"-p {port} -k {sock} -c listen_addresses=127.0.0.1", "start"],
                   check=True, capture_output=True)

    def db(name: str) -> str:
        con = psycopg2.connect(host="127.0.0.1", port=port, user="modesel", dbname="postgres")
        con.autocommit = True
        con.cursor().execute(f"CREATE DATABASE {name}")
        con.close()
        return f"postgresql://modesel@127.0.0.1:{port}/{name}"
    try:
        yield db
    finally:
        subprocess.run(prefix + [pg_ctl, "-D", data, "-m", "immediate", "stop"], capture_output=True)
        shutil.rmtree(root, ignore_errors=True)


def bench_postgres(label: str, study: Path, n_sets: int) -> list:
    """One `modesel worker` doing `n_sets` against two doing half each, at once
    (one process each, sharing one reference cache, built before timing)."""
    rows = []
    with full_budget_copy(study) as copy, throwaway_postgres() as db, \
            tempfile.TemporaryDirectory(prefix="bench-search-cache-") as cache:
        name = study_name(study)
        url = db("warmup")                      # compile, load, build the reference once (not timed)
        modesel("worker", str(copy), "--storage", url, "--n-trials", "1", "--n-jobs", "1", "--cache", cache)
        for n_workers in (1, 2):
            url = db(f"workers{n_workers}")
            share = [n_sets // n_workers + (1 if i < n_sets % n_workers else 0) for i in range(n_workers)]
            t0 = time.perf_counter()
            with ThreadPoolExecutor(n_workers) as pool:      # the worker processes run at once
                # one process per worker: the study file's own [run] n_jobs (2 for the tower study)
                # would run 2 processes per worker and make "1 worker" a 2-process run
                list(pool.map(lambda n: modesel("worker", str(copy), "--storage", url, "--n-trials", str(n),
                                                "--n-jobs", "1", "--cache", cache), share))
            wall = time.perf_counter() - t0
            rows.append((label, f"{n_workers} worker{'s' if n_workers > 1 else ''} (PostgreSQL)",
                         search_rates(url, name), wall))
    return rows


def _spin(n: int) -> float:
    t0 = time.perf_counter()
    sum(i * i for i in range(n))
    return time.perf_counter() - t0


def _parallel_ratio(work, n: int, jobs: int) -> float:
    """Throughput of `jobs` forked processes each running `work(n)` (which
    returns its wall [s]) at once, relative to one process running it."""
    import multiprocessing
    one = work(n)
    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        t0 = time.perf_counter()
        pool.map(work, [n] * jobs)
        together = time.perf_counter() - t0
    return jobs * one / together


def machine_ceiling(jobs: int, n: int = 20_000_000) -> float:
    """Throughput of `jobs` processes running the same pure-Python loop at
    once, relative to one: the most any `--n-jobs` can gain on this machine
    right now (other users' load included)."""
    return _parallel_ratio(_spin, n, jobs)


_SCENE = None


def _simulate_n(n: int) -> float:
    """Wall [s] of n simulations of the probe's scene (`_SCENE`, set before forking)."""
    from modesel.simulation.api import simulate
    scene, tmax, dt = _SCENE
    t0 = time.perf_counter()
    for _ in range(n):
        simulate(scene, tmax=tmax, dt=dt)
    return time.perf_counter() - t0


def simulation_ceiling(study: Path, jobs: int, seconds: float = 3.0) -> float:
    """Throughput of `jobs` processes simulating the study's first scene (its
    default mode set, the study's tmax and dt) at once, relative to one
    process: the ceiling of the search's speed-up set by the simulations
    alone, which touch more memory than `machine_ceiling`'s loop and so feel
    the other processes' use of the shared caches (on a 2-core machine from
    1.0x to 1.35x more CPU per simulation between runs). About `seconds` per
    round; forked after a warm-up, so numba's code is loaded once."""
    import tomllib

    from modesel.simulation.api import simulate
    from modesel.simulation.scene import load_scene
    global _SCENE
    spec = tomllib.loads(study.read_text())["scene"][0]
    scene = load_scene(study.parent / spec["path"])
    _SCENE = (scene, spec.get("tmax"), spec.get("dt"))
    t0 = time.perf_counter()
    simulate(scene, tmax=_SCENE[1], dt=_SCENE[2])            # warm (cache loaded before the fork)
    n = max(3, int(seconds / max(time.perf_counter() - t0, 1e-3)))
    n = max(3, int(n * seconds / max(_simulate_n(n), 1e-3)))      # about `seconds` per round
    return _parallel_ratio(_simulate_n, n, jobs)


def print_rows(rows: list) -> None:
    print(f"{'study':<9} {'mode':<26} {'trials':>6} {'sets':>5} {'search [s]':>10} {'trials/min':>10} "
          f"{'sets/min':>9} {'speed-up':>8} {'whole [s]':>9} {'whole sets/min':>14}")
    base = {}
    for label, mode, r, wall in rows:
        per_min = 60.0 * r["sets"] / r["span"] if r["span"] > 0 else float("nan")
        key = (label, "PostgreSQL" in mode)
        base.setdefault(key, per_min)
        print(f"{label:<9} {mode:<26} {r['trials']:>6} {r['sets']:>5} {r['span']:>10.1f} "
              f"{60.0 * r['trials'] / r['span']:>10.1f} {per_min:>9.1f} {per_min / base[key]:>7.2f}x "
              f"{wall:>9.1f} {60.0 * r['sets'] / wall:>14.1f}", flush=True)


def main_bench() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--tower-sets", type=int, default=60, help="sets simulated per run (tower study)")
    p.add_argument("--turbine-sets", type=int, default=8, help="sets simulated per run (turbine study)")
    p.add_argument("--max-jobs", type=int, default=os.cpu_count() or 1, help="N (default: the cores)")
    p.add_argument("--jobs", type=lambda s: sorted({int(j) for j in s.split(",")}),
                   help="the job counts of the curve, comma-separated (default: 1..N)")
    p.add_argument("--skip-tower", action="store_true")
    p.add_argument("--skip-turbine", action="store_true")
    p.add_argument("--skip-postgres", action="store_true")
    a = p.parse_args()
    jobs = a.jobs or list(range(1, a.max_jobs + 1))
    a.max_jobs = max(jobs)
    print(f"{os.cpu_count()} cores; load average {os.getloadavg()[0]:.1f} (1 min) before; a CPU-bound "
          f"loop in {a.max_jobs} processes runs {machine_ceiling(a.max_jobs):.2f}x as fast as in one "
          f"(the ceiling of any speed-up now)", flush=True)
    rows = []
    for label, skip in (("tower", a.skip_tower), ("turbine", a.skip_turbine)):
        if skip:
            continue
        before = simulation_ceiling(STUDIES[label], a.max_jobs)
        rows += bench_jobs(label, STUDIES[label], a.tower_sets if label == "tower" else a.turbine_sets, jobs)
        after = simulation_ceiling(STUDIES[label], a.max_jobs)
        print(f"  {label}: its scene's simulation alone in {a.max_jobs} processes at once runs {before:.2f}x "
              f"(before the runs) and {after:.2f}x (after) as fast as in one (the ceiling the simulations "
              f"set)", flush=True)
        print_rows(rows)
    if not a.skip_postgres:
        try:
            if not a.skip_tower:
                rows += bench_postgres("tower", STUDIES["tower"], a.tower_sets)
            if not a.skip_turbine:
                rows += bench_postgres("turbine", STUDIES["turbine"], a.turbine_sets)
        except RuntimeError as exc:
            print(f"PostgreSQL mode skipped: {exc}")
    print()
    print_rows(rows)
    print(f"load average {os.getloadavg()[0]:.1f} (1 min) after; a CPU-bound loop in {a.max_jobs} processes "
          f"runs {machine_ceiling(a.max_jobs):.2f}x as fast as in one; speed-up: sets/min of the search "
          f"relative to --n-jobs 1 (or to one PostgreSQL worker)")


if __name__ == "__main__":
    main_bench()
