"""Speed of the multibody engine: simulated seconds per wall-clock second.

    python benchmarks/bench_engine.py [--tmax 60] [--runs 5]

Cases on the NREL 5-MW land turbine (ElastoDyn deck in modesel/turbine/data):
  land_3dof       tower FA 1 + SS 1 (elastodyn shapes), rotor free (GeAz), rigid blades
  land_tower4     the same with 4 'clamped' modes per tower direction (9 DOFs)
  full_turbine    tower FA/SS/torsion 1 each, 3 blades x (flap 1 + edge 1), GeAz + DrTr
                  (11 DOFs; torsion 'clamped')
  full_4modes     the same fields with 4 'clamped' modes each (38 DOFs)
Free decay from a 1 m tower-top (and 1 m / 0.5 m blade-tip flap / edge)
deflection at 12.1 rpm, gravity, geometric stiffening and structural damping
on, rtol 1e-8, outputs every 0.01 s. Method as `choose_method` picks it from
the oscillating modes of the linearised model (compiled-DOP853 below a
stiffness ratio of 200, else Radau).

Timed: the integration loop (`integrate` with the compiled right-hand side),
median of `--runs` runs after one warm-up run (which also loads or builds
the numba cache); model build and compilation are excluded. Also printed:
the number of right-hand-side evaluations and their mean cost inside the
loop, one evaluation through the Python path `Built.M_F` (used when a load
effect such as aerodynamics acts), and one whole `api.simulate` call
(build, linearisation, integration, output channels).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from modesel.modeset import FieldModes, ModeSet
from modesel.simulation import api
from modesel.multibody import linearize as lin
from modesel.turbine.elastodyn import load_turbine
from modesel.multibody.integrate import choose_method, integrate
from modesel.multibody.compiled import CompiledRHS
from modesel.simulation.scene import Scene


def cases(turbine):
    ed = lambda n: FieldModes("elastodyn", n)            # noqa: E731
    cl = lambda n: FieldModes("clamped", n)              # noqa: E731
    tower = {"TTDspFA": 1.0, "RotSpeed": 12.1 * np.pi / 30}
    blades = dict(tower, OoPDefl=1.0, IPDefl=0.5)
    return {
        "land_3dof": (ModeSet({"tower_fa": ed(1), "tower_ss": ed(1)}), ("GeAz",), tower),
        "land_tower4": (ModeSet({"tower_fa": cl(4), "tower_ss": cl(4)}), ("GeAz",), tower),
        "full_turbine": (ModeSet({"tower_fa": ed(1), "tower_ss": ed(1), "tower_torsion": cl(1),
                                "blade_flap": ed(1), "blade_edge": ed(1)}), ("GeAz", "DrTr"), blades),
        "full_4modes": (ModeSet({f: cl(4) for f in ("tower_fa", "tower_ss", "tower_torsion",
                                                    "blade_flap", "blade_edge")}), ("GeAz", "DrTr"), blades),
    }


def bench(name, modeset, free, initial, turbine, tmax, runs):
    scene = Scene(name, turbine, tmax, 0.01, modeset, free, {}, {}, initial,
                  {"gravity": True, "geometric_stiffening": True, "damping": True}, {})
    built = api.build(scene)
    rhs = built.rhs()                                   # compiled: only linear loads (drivetrain)
    assert isinstance(rhs, CompiledRHS), "a load effect acts: not the compiled path"
    model = lin.linearize(rhs, np.zeros_like(built.q0), built.qd0, built.model.system.free)
    # stiffness ratio over the oscillating modes: the slow real eigenvalue pair
    # of the free rotor (gravity on an unbalanced rotor, damping ratio +-1)
    # is not a vibration mode
    omegas = np.array([2 * np.pi * m.frequency_hz for m in lin.modes(model) if abs(m.damping_ratio) < 1.0])
    method, ratio = choose_method(omegas, "auto", rhs)
    bounds = api.divergence_bounds(built)

    def run():
        return integrate(rhs, built.q0, built.qd0, tmax, 0.01, method=method, bounds=bounds,
                         stiffness_ratio=ratio)

    first = run()                                       # warm-up (numba cache load or compile)
    walls = []
    for _ in range(runs):
        t0 = time.perf_counter()
        res = run()
        walls.append(time.perf_counter() - t0)
    assert np.array_equal(res.q, first.q)
    wall = float(np.median(walls))
    q, qd = built.q0 + 0.01, built.qd0 + 0.01
    k = 200
    built.M_F(0.3, q, qd)                               # warm-up
    t0 = time.perf_counter()
    for _ in range(k):
        built.M_F(0.3, q, qd)
    t_python = (time.perf_counter() - t0) / k
    t0 = time.perf_counter()
    api.simulate(scene)
    t_simulate = time.perf_counter() - t0
    print(f"{name:12s} {len(built.q0):3d} DOF  {method:15s} ratio {ratio:6.1f}  n_rhs {res.n_rhs:6d}  "
          f"wall {wall:7.4f} s  speed {tmax / wall:7.1f} x real time  {wall / res.n_rhs * 1e6:5.1f} us/rhs  "
          f"M_F {t_python * 1e6:5.1f} us  simulate {t_simulate:7.3f} s", flush=True)
    return wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tmax", type=float, default=60.0, help="simulated time [s]")
    ap.add_argument("--runs", type=int, default=5, help="timed runs (median)")
    ap.add_argument("--cases", nargs="*", default=None, help="subset of case names")
    args = ap.parse_args(argv)
    turbine = load_turbine("nrel5mw")
    for name, (ms, free, init) in cases(turbine).items():
        if args.cases and name not in args.cases:
            continue
        bench(name, ms, free, init, turbine, args.tmax, args.runs)


if __name__ == "__main__":
    main()
