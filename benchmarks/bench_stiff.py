"""Stiff and large systems: wall time of `simulate` with the method "auto"
picks (compiled-Radau for these) and, with --compare, the explicit
compiled-DOP853 and scipy's Radau forced on the same case.

Cases:
- "tower41": studies/scenes/paper_3dof_land.toml with `cosine:20` per tower
  direction (41 DOFs, modes 0.32-673 Hz, stiffness ratio about 2100), a
  1-m free decay at 5 rpm, 20 s;
- "turbine91": studies/scenes/turbine_parked_free_decay.toml (the full
  NREL 5-MW structure) with `fem:10` for every field (91 DOFs), 20 s;
- "turbine91aero": studies/scenes/turbine_wind_11p4.toml (BEM aero, tower
  drag, generator, drivetrain) with `fem:10` for every field, 20 s.

Each case runs once for 0.5 s to load the compiled code (not timed), then
`--repeat` times. "simulate" is the whole `simulate` call (build, static
check and linearisation, integration, output channels); "CPU" its process
time, less sensitive to other jobs on a shared machine.

    python3 benchmarks/bench_stiff.py [--cases tower41,turbine91,turbine91aero] [--tmax 20] [--repeat 1] [--compare]
"""
from __future__ import annotations

import argparse
import copy
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from modesel.modeset import FieldModes, ModeSet  # noqa: E402
from modesel.simulation.api import load_scene, simulate  # noqa: E402

HERE = os.path.dirname(__file__)
SCENES = os.path.join(HERE, "..", "studies", "scenes")
ALL_FIELDS = ("tower_fa", "tower_ss", "tower_torsion", "blade_flap", "blade_edge")
CASES = {
    "tower41": ("paper_3dof_land.toml", ModeSet({"tower_fa": FieldModes("cosine", 20),
                                                  "tower_ss": FieldModes("cosine", 20)})),
    "turbine91": ("turbine_parked_free_decay.toml", ModeSet({f: FieldModes("fem", 10) for f in ALL_FIELDS})),
    "turbine91aero": ("turbine_wind_11p4.toml", ModeSet({f: FieldModes("fem", 10) for f in ALL_FIELDS})),
}


def run(scene, modeset, tmax, method=None):
    sc = copy.deepcopy(scene)
    if method is not None:
        sc.solver["method"] = method
    w0, c0 = time.perf_counter(), time.process_time()
    result = simulate(sc, modeset, tmax=tmax)
    return time.perf_counter() - w0, time.process_time() - c0, result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", default="tower41,turbine91,turbine91aero")
    p.add_argument("--tmax", type=float, default=20.0)
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--compare", action="store_true",
                   help="also force compiled-DOP853 and scipy's Radau (minutes for tower41)")
    args = p.parse_args(argv)
    print(f"{'case':<14} {'DOFs':>5} {'ratio':>7} {'method':>16} {'RHS':>8} {'simulate [s]':>13} {'CPU [s]':>8} "
          f"{'x real time':>12}")
    for name in args.cases.split(","):
        file, modeset = CASES[name]
        scene = load_scene(os.path.join(SCENES, file))
        methods = [None] + (["compiled-DOP853", "Radau"] if args.compare else [])
        for method in methods:
            run(scene, modeset, 0.5, method)                  # load compiled code
            for _ in range(args.repeat):
                wall, cpu, r = run(scene, modeset, args.tmax, method)
                print(f"{name:<14} {r.n_dofs:>5} {r.stiffness_ratio:>7.0f} {r.method:>16} {r.n_rhs:>8} "
                      f"{wall:>13.2f} {cpu:>8.2f} {args.tmax / wall:>12.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
