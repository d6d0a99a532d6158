"""`modesel simulate` against OpenFAST on the same case, whole process:
studies/data/openfast/steady_08/steady_08.fst (NREL 5-MW, 8 m/s, AeroDyn
BEM, ServoDyn VSContrl 1, 15 DOFs) for 20 s and 100 s.

Both run as separate processes one after the other (modesel first once,
untimed, so numba's on-disk cache and Python's bytecode of modesel are warm:
PYTHONDONTWRITEBYTECODE, set on some machines, is dropped for modesel's runs;
without bytecode every run compiles modesel's sources again, about 0.3 s). OpenFAST runs on a copy of the
case folder with TMax replaced; its executable is $OPENFAST or
../shared/tools/openfast/openfast relative to the repository. Without it,
the OpenFAST wall time of the bundled log (`steady_08.log`, 100 s) is
reported instead and scaled to 20 s.

modesel runs twice per round: by itself (a fresh process pays Python's,
numpy's and numba's start, about 0.5 s) and served (`modesel serve` started
by the benchmark on a private socket; the command is the same, a fresh
client process that hands it to the warm server, `modesel.server`; the
server warms itself on the case after the untimed first run, as it does
for any scene after its first request). Both write the same CSV (checked).
--no-server leaves the served runs out.

Each triple runs `--repeat` times, interleaved (modesel, modesel served,
OpenFAST, modesel, ...); the best wall time of each is reported (the
machine's own noise, often 20-40 % on a shared virtual machine, only ever
adds time), with the ratio of the bests.

    python3 benchmarks/bench_openfast.py [--tmax 20 100] [--repeat 3] [--no-server]
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

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "studies" / "data" / "openfast"
FST = CASE / "steady_08" / "steady_08.fst"


def openfast_exe():
    exe = os.environ.get("OPENFAST") or str(ROOT.parent / "shared" / "tools" / "openfast" / "openfast")
    return exe if Path(exe).is_file() else None


def modesel_env(server="off"):
    env = dict(os.environ, PYTHONPATH=str(ROOT), MODESEL_SERVER=str(server))
    env.pop("PYTHONDONTWRITEBYTECODE", None)     # warm: Python's bytecode of modesel written once, then read
    return env


def start_server(folder):
    """`modesel serve` on a socket in `folder`, once it listens: (process, socket)."""
    sock, log = Path(folder) / "s.sock", Path(folder) / "server.log"
    with open(log, "w") as out:
        proc = subprocess.Popen([sys.executable, "-m", "modesel", "serve", "--socket", str(sock), "--idle-exit",
                                 "900"], stdout=out, stderr=subprocess.STDOUT, env=modesel_env())
    end = time.monotonic() + 600
    while "listening on" not in log.read_text():
        if proc.poll() is not None or time.monotonic() > end:
            raise SystemExit(f"modesel serve did not start:\n{log.read_text()}")
        time.sleep(0.05)
    return proc, sock


def run_modesel(tmax, out, server="off"):
    env = modesel_env(server)
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "modesel", "simulate", str(FST), "--tmax", str(tmax),
                           "--out", str(out)], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode:
        raise SystemExit(proc.stderr)
    return wall, proc.stdout.strip()


def run_openfast(exe, tmax, folder):
    work = Path(folder) / "openfast"
    shutil.copytree(CASE, work)
    fst = work / "steady_08" / "steady_08.fst"
    text = re.sub(r"^\s*[-+0-9.eE]+(\s+TMax)", rf"{tmax}\1", fst.read_text(), flags=re.M)
    fst.write_text(text)
    start = time.perf_counter()
    proc = subprocess.run([exe, fst.name], cwd=fst.parent, capture_output=True, text=True)
    wall = time.perf_counter() - start
    shutil.rmtree(work)
    if proc.returncode:      # a missing runtime library is on stderr, OpenFAST's own errors on stdout
        raise SystemExit(f"OpenFAST ({exe}) failed with exit code {proc.returncode}:\n"
                         + (proc.stderr.strip() or proc.stdout[-2000:]))
    return wall


def logged_openfast(tmax):
    """OpenFAST's own 'Total Real Time' [s] of the bundled 100-s log, scaled to tmax."""
    log = (FST.parent / "steady_08.log").read_text(errors="replace")
    m = re.search(r"Total Real Time:\s*([0-9.]+)\s*seconds", log)
    return None if m is None else float(m.group(1)) * tmax / 100.0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tmax", type=float, nargs="+", default=[20.0, 100.0])
    p.add_argument("--repeat", type=int, default=3, help="runs of each; the best is reported")
    p.add_argument("--no-server", action="store_true", help="leave out the runs served by `modesel serve`")
    args = p.parse_args(argv)
    exe = openfast_exe()
    with tempfile.TemporaryDirectory() as folder:
        out, served_out = Path(folder) / "modesel.csv", Path(folder) / "served.csv"
        run_modesel(1.0, out)                                  # warm numba's cache
        server = None if args.no_server else start_server(folder)
        try:
            if server:
                run_modesel(1.0, served_out, server[1])        # the server then warms itself on the case
            print(f"{'tmax [s]':>9} {'modesel [s]':>12} {'served [s]':>11} {'OpenFAST [s]':>13} {'ratio':>6} "
                  f"{'served':>7}  source")
            for tmax in args.tmax:
                walls, served, refs = [], [], []
                for _ in range(max(1, args.repeat)):
                    wall, line = run_modesel(tmax, out)
                    walls.append(wall)
                    if server:
                        served.append(run_modesel(tmax, served_out, server[1])[0])
                        if served_out.read_bytes() != out.read_bytes():
                            raise SystemExit("the served run wrote another CSV than the run by itself")
                    if exe:
                        refs.append(run_openfast(exe, tmax, folder))
                wall = min(walls)
                if exe:
                    ref, source = min(refs), f"OpenFAST run (best of {len(refs)})"
                else:
                    ref, source = logged_openfast(tmax), "OpenFAST log (scaled)"
                nan = float("nan")
                ratio = ref / wall if ref else nan
                best = min(served) if served else nan
                print(f"{tmax:>9.0f} {wall:>12.2f} {best:>11.2f} {ref or nan:>13.2f} {ratio:>6.2f} "
                      f"{(ref or nan) / best:>7.2f}  {source}")
                print(f"          {line}")
        finally:
            if server:
                server[0].terminate()
                server[0].wait(timeout=60)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
