"""Cost of the pieces of one compiled right-hand side [us per call] of the
full turbine (studies/scenes/turbine_wind_11p4.toml: BEM, tower drag,
generator) with FAMILY:COUNT modes in every field (default fem:4, the
38-DOF case of `bench_turbine.py`): the whole right-hand side with the
solve (`kernel.free_system`, its cfunc `system_function.FREE_SYSTEM`
called through a pointer as the integrators call it), the bodies' frames (`kernel.kinematics`),
the effects' loads (the `effect_loads` cfunc) and the assembly of M and F
with the node forces (`kernel.assemble`), each in a compiled loop of
--calls calls after one warm-up (so numba's dispatch is not timed), at a
state near the scene's static equilibrium, at the scene's own speeds (the
rotor turning). The first run compiles the
loops (about a minute).

    python3 benchmarks/rhs_pieces.py [--family fem] [--count 4] [--calls 3000]
    python3 benchmarks/rhs_pieces.py --scene studies/data/openfast/steady_08/steady_08.fst --scene-modes
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from numba import njit

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from modesel.modeset import FieldModes, ModeSet  # noqa: E402
from modesel.multibody import kernel  # noqa: E402
from modesel.multibody.system_function import FREE_SYSTEM  # noqa: E402
from modesel.simulation.api import load_scene  # noqa: E402
from modesel.simulation.assembly import build  # noqa: E402

SCENE = os.path.join(os.path.dirname(__file__), "..", "studies", "scenes", "turbine_wind_11p4.toml")
FIELDS = ("tower_fa", "tower_ss", "tower_torsion", "blade_flap", "blade_edge")


@njit
def _free(n, system, t, x, out, inf, prob, rwork, data, work):
    for i in range(n):
        system(t + 1e-9 * i, x, out, kernel.SOLVE, inf, prob, rwork, data, work)


@njit
def _kinematics(n, q, qd, data, work):
    for i in range(n):
        kernel.kinematics(q, qd, data, work)


@njit
def _loads(n, loads, t, q, qd, gen, fnodes, fflag, work):
    fn, ints, floats, state = loads
    for i in range(n):
        fn(t, q, qd, work[0], work[1], gen, fnodes, fflag, ints, floats, state, 0)


@njit
def _assemble(n, q, qd, gvec, fnodes, fflag, gen, data, work, M, F):
    for i in range(n):
        kernel.assemble(q, qd, gvec, fnodes, fflag, gen, data, work, M, F, False)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--family", default="fem")
    p.add_argument("--count", type=int, default=4)
    p.add_argument("--calls", type=int, default=3000)
    p.add_argument("--scene", default=SCENE, help="scene file (.toml or an OpenFAST .fst)")
    p.add_argument("--scene-modes", action="store_true",
                   help="the scene's own mode set (an .fst: the deck's) instead of --family/--count")
    a = p.parse_args(argv)
    modes = None if a.scene_modes else ModeSet({f: FieldModes(a.family, a.count) for f in FIELDS})
    built = build(load_scene(a.scene), modes)
    rhs = built.rhs()
    n, packed, prob, rwork = rhs.n_free, rhs.packed, rhs.prob, rhs.rwork
    x = np.zeros(2 * n)
    x[:n] = np.asarray(built.q0, float)[:n]
    # the scene's own speeds (its rotor turning), not near rest: below a tip-speed
    # ratio of 1 the BEM has no inductions to solve (`aero.bem.bem_weight`), which
    # made the loads look a third of their cost (steady_08: 17.2 us against 49.2 us)
    x[n:] = np.asarray(built.qd0, float)[:n] + 0.01
    out, inf = np.zeros(2 * n), np.full(n, np.inf)
    kernel.call_system(FREE_SYSTEM, 1.0, x, out, kernel.SOLVE, inf, prob, rwork, packed.data, packed.work)
    q, qd = rwork[0][0].copy(), rwork[0][1].copy()
    gen = np.zeros(len(q))
    M, F = np.zeros((len(q), len(q))), np.zeros(len(q))
    pieces = {
        "right-hand side (free_system, with the solve)":
            lambda k: _free(k, FREE_SYSTEM, 1.0, x, out, inf, prob, rwork, packed.data, packed.work),
        "frames (kinematics)": lambda k: _kinematics(k, q, qd, packed.data, packed.work),
        "loads (effect_loads)": lambda k: _loads(k, prob[9], 1.0, q, qd, gen, prob[7], prob[8], packed.work),
        "M and F with node forces (assemble)":
            lambda k: _assemble(k, q, qd, prob[4], prob[7], prob[8], gen, packed.data, packed.work, M, F),
    }
    what = "the scene's own modes" if a.scene_modes else f"{a.family}:{a.count} in every field"
    print(f"{os.path.basename(a.scene)}, {what}: {n} DOFs, {rhs.eq.n_bodies} bodies")
    for name, f in pieces.items():
        f(1)
        t0 = time.perf_counter()
        f(a.calls)
        print(f"  {name:<48} {1e6 * (time.perf_counter() - t0) / a.calls:8.1f} us")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
