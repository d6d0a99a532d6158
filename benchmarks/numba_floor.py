"""What numba itself costs a fresh process before modesel does anything:
importing numpy, importing numba, and the first call of a trivial function
loaded from numba's on-disk cache (numba then builds its typing and target
contexts and links the cached code), each timed in a new interpreter, with
the cache warmed by one run first. This floor is paid by every `modesel
simulate`; issue 12 asks for at most 0.5 s outside integration. Two variants:
numba alone, whose first call imports the package scipy.linalg (numba's BLAS
check), and as modesel pays it, with scipy's BLAS module loaded alone before
(`blas.load_scipy_blas`, untimed).

    python3 benchmarks/numba_floor.py [--repeat 5]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

MODULE = '''from numba import njit


@njit(cache=True)
def f(x):
    return x + 1.0
'''

PROBE = '''import sys
import time
BLAS_ALONE = sys.argv[1:] == ["blas-alone"]
t0 = time.perf_counter()
import numpy
t1 = time.perf_counter()
import numba
t2 = time.perf_counter()
if BLAS_ALONE:      # as modesel does before numba's first call (blas.load_scipy_blas), untimed
    from modesel.multibody.blas import load_scipy_blas
    load_scipy_blas()
import tiny
t3 = time.perf_counter()
tiny.f(1.0)
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t4 - t3)
'''


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=5)
    a = p.parse_args(argv)
    root = str(Path(__file__).resolve().parents[1])
    names = ("import numpy", "import numba", "first call of a cached function")
    with tempfile.TemporaryDirectory() as d:
        Path(d, "tiny.py").write_text(MODULE)
        Path(d, "probe.py").write_text(PROBE)
        env = {"PYTHONPATH": os.pathsep.join([d, root]), "NUMBA_CACHE_DIR": str(Path(d, "cache")), "PATH": ""}
        subprocess.run([sys.executable, "probe.py"], cwd=d, env=env, check=True, capture_output=True)   # warm
        for variant, title in (([], "numba alone (its first call imports the package scipy.linalg)"),
                               (["blas-alone"], "as modesel pays it (scipy's BLAS module loaded alone first)")):
            runs = []
            for _ in range(a.repeat):
                out = subprocess.run([sys.executable, "probe.py", *variant], cwd=d, env=env, check=True,
                                     capture_output=True, text=True).stdout
                runs.append([float(v) for v in out.split()])
            print(f"{title}; fresh interpreter, {a.repeat} runs (median, min-max):")
            for k, name in enumerate(names):
                v = [r[k] for r in runs]
                print(f"  {name:<34} {statistics.median(v):6.3f} s  ({min(v):.3f}-{max(v):.3f} s)")
            total = [sum(r) for r in runs]
            print(f"  {'together':<34} {statistics.median(total):6.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
