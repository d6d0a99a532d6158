"""Wall time of `modesel simulate steady_08.fst` (the whole process: start-up,
reading the decks, building, compiling from cache, 100 s of simulation,
writing the CSV) against OpenFAST 5.0 on the same case.

OpenFAST's time: the executable run on a copy of the case when it is
present (env OPENFAST or ../shared/tools/openfast/openfast relative to the
repository), else the "Total Real Time" of the committed run log
(studies/data/openfast/steady_08/steady_08.log; that run was on another,
unloaded machine, so the ratio is only indicative).

    python3 benchmarks/bench_openfast_simulate.py [--case steady_08] [--tmax 100]

Prints both wall times [s] and their ratio (modesel / OpenFAST).
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "studies" / "data" / "openfast"


def openfast_executable() -> Path | None:
    for candidate in (os.environ.get("OPENFAST"), ROOT.parent / "shared" / "tools" / "openfast" / "openfast"):
        if candidate and Path(candidate).is_file() and os.access(candidate, os.X_OK):
            return Path(candidate)
    return None


def logged_time(case: str) -> float:
    text = (CASES / case / f"{case}.log").read_text(errors="replace")
    return float(re.search(r"Total Real Time:\s*([0-9.]+)", text).group(1))


def time_openfast(exe: Path, case: str, tmax: float) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copytree(CASES / case, Path(tmp) / case)
        shutil.copytree(CASES / "common", Path(tmp) / "common")
        fst = Path(tmp) / case / f"{case}.fst"
        lines = fst.read_text().splitlines()
        for i, line in enumerate(lines):
            if line.split()[1:2] == ["TMax"]:
                lines[i] = f"{tmax:>12}   TMax   - edited by bench_openfast_simulate"
        fst.write_text("\n".join(lines) + "\n")
        start = time.perf_counter()
        subprocess.run([str(exe), fst.name], cwd=fst.parent, check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        return time.perf_counter() - start


def time_modesel(case: str, tmax: float) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "modesel", "simulate", str(CASES / case / f"{case}.fst"),
                        "--tmax", str(tmax), "--out", str(Path(tmp) / "out.csv")], check=True, env=env,
                       stdout=subprocess.DEVNULL)
        return time.perf_counter() - start


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", default="steady_08")
    parser.add_argument("--tmax", type=float, default=100.0, help="simulated time [s]")
    args = parser.parse_args(argv)
    exe = openfast_executable()
    if exe is not None:
        ref, how = time_openfast(exe, args.case, args.tmax), f"OpenFAST run here ({exe})"
    else:
        ref = logged_time(args.case) * args.tmax / 100.0
        how = f"OpenFAST log of {args.case} (100 s run, scaled to {args.tmax:g} s)"
    mine = time_modesel(args.case, args.tmax)
    print(f"{args.case}, {args.tmax:g} s simulated")
    print(f"  modesel simulate (whole process): {mine:8.1f} s wall")
    print(f"  {how}: {ref:8.1f} s wall")
    print(f"  ratio modesel / OpenFAST: {mine / ref:.2f}")


if __name__ == "__main__":
    main()
