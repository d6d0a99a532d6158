"""Right-hand sides and accuracy of the explicit methods on one scene:
compiled-DOP853 and compiled-RK45 at several tolerances, against
compiled-DOP853 at rtol 1e-10 / atol 1e-11. The error is the largest
difference of any free coordinate (or its rate) over the run, relative to
that coordinate's range (a rate: its range or largest magnitude), so a
coordinate that barely moves does not hide. Backs `integrate.LOW_ORDER_RTOL`
and the OpenFAST case's tolerances with AeroDyn (`simulation.fst.SOLVER_BEM`).

    python3 benchmarks/bench_methods.py [SCENE] [--tmax 20]
    (default SCENE: the OpenFAST case steady_08)
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from modesel.multibody.integrate import integrate  # noqa: E402
from modesel.simulation.api import load_scene  # noqa: E402
from modesel.simulation.assembly import build  # noqa: E402

CASES = (("compiled-DOP853", 1e-5, 1e-6), ("compiled-DOP853", 1e-5, 1e-5), ("compiled-RK45", 1e-5, 1e-6),
         ("compiled-RK45", 1e-5, 1e-5), ("compiled-RK45", 3e-6, 3e-7), ("compiled-RK45", 1e-6, 1e-7))


def errors(run, ref):
    """Per coordinate and rate: largest difference relative to the range."""
    e = [np.abs(run.q[:, i] - ref.q[:, i]).max() / max(np.ptp(ref.q[:, i]), 1e-12) for i in range(ref.q.shape[1])]
    e += [np.abs(run.qd[:, i] - ref.qd[:, i]).max() / max(np.ptp(ref.qd[:, i]), np.abs(ref.qd[:, i]).max(), 1e-12)
          for i in range(ref.q.shape[1])]
    return np.array(e)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", nargs="?", default=str(REPO / "studies/data/openfast/steady_08/steady_08.fst"))
    p.add_argument("--tmax", type=float, default=20.0, help="simulated time [s]")
    a = p.parse_args(argv)
    scene = load_scene(a.scene)
    b = build(scene, None, reactions=True)
    rhs = b.rhs()
    names = list(b.model.system.free)
    integrate(rhs, b.q0, b.qd0, 0.1, 0.05, method="compiled-RK45", rtol=1e-5, atol=1e-6)   # load compiled code
    ref = integrate(rhs, b.q0, b.qd0, a.tmax, scene.dt, method="compiled-DOP853", rtol=1e-10, atol=1e-11)
    print(f"{Path(a.scene).name}, {a.tmax:g} s, {len(names)} DOFs; reference compiled-DOP853 at 1e-10 / 1e-11: "
          f"{ref.n_rhs} right-hand sides")
    print(f"{'method':<16} {'rtol':>6} {'atol':>6} {'RHS':>7} {'wall [s]':>9} {'largest error [-]':>18} "
          f"{'median error [-]':>17}  worst coordinate")
    for method, rtol, atol in CASES:
        t = time.perf_counter()
        run = integrate(rhs, b.q0, b.qd0, a.tmax, scene.dt, method=method, rtol=rtol, atol=atol)
        wall = time.perf_counter() - t
        e = errors(run, ref)
        k = int(np.argmax(e))
        worst = names[k] if k < len(names) else f"d{names[k - len(names)]}/dt"
        print(f"{method:<16} {rtol:6.0e} {atol:6.0e} {run.n_rhs:7d} {wall:9.3f} {e.max():18.1e} "
              f"{np.median(e):17.1e}  {worst}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
