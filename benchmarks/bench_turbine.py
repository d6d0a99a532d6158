"""Wall time and speed (simulated seconds per wall-clock second) of the full
NREL 5-MW model in steady 11.4 m/s wind (studies/scenes/turbine_wind_11p4.toml:
BEM aerodynamics, tower drag, variable-speed generator, drivetrain), 60 s,
on one core:

- 1 mode per field (tower FA, SS, torsion; blade flap, edge x 3) + GeAz + DrTr;
- 4 modes per field ("fem" family for every field).

Each case runs once to load the compiled kernels (not timed), then `--repeat`
times; the best and median wall times are reported. "wall" is the whole
`simulate` call: build (shapes, bodies, static equilibrium), method choice,
integration and output channels (including the reaction loads);
"integration" is `SimulationResult.wall_time_s` (without the channels);
"CPU" the process time of the best run (less sensitive to other jobs on a
shared machine). --method forces a method (default: the scene's, "auto"
unless it names one), e.g. compiled-Radau.

    python3 benchmarks/bench_turbine.py [--tmax 60] [--repeat 3] [--method compiled-Radau]
"""
from __future__ import annotations

import argparse
import copy
import os
import statistics
import sys
import time


sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from modesel.modeset import FieldModes, ModeSet  # noqa: E402
from modesel.simulation.api import load_scene, simulate  # noqa: E402

SCENE = os.path.join(os.path.dirname(__file__), "..", "studies", "scenes", "turbine_wind_11p4.toml")
FIELDS = ("tower_fa", "tower_ss", "tower_torsion", "blade_flap", "blade_edge")


def cases():
    yield "1 mode per field", None
    yield "4 modes per field (fem)", ModeSet({f: FieldModes("fem", 4) for f in FIELDS})


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tmax", type=float, default=60.0)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--method", default=None, help="force this integration method")
    args = p.parse_args(argv)
    scene = load_scene(SCENE)
    if args.method:
        scene.solver["method"] = args.method
    print(f"{'case':<26} {'DOFs':>5} {'method':>16} {'RHS':>7} {'wall best [s]':>14} {'median [s]':>11} "
          f"{'x real time':>12} {'integration [s]':>16} {'CPU [s]':>8}")
    for name, modeset in cases():
        simulate(copy.deepcopy(scene), modeset, tmax=1.0)        # load compiled code
        runs = []
        for _ in range(args.repeat):
            start, cpu = time.perf_counter(), time.process_time()
            result = simulate(copy.deepcopy(scene), modeset, tmax=args.tmax)
            runs.append((time.perf_counter() - start, time.process_time() - cpu, result))
        walls = [w for w, _, _ in runs]
        best_wall, best_cpu, best = min(runs, key=lambda r: r[0])
        print(f"{name:<26} {best.n_dofs:>5} {best.method:>16} {best.n_rhs:>7} {best_wall:>14.2f} "
              f"{statistics.median(walls):>11.2f} {args.tmax / best_wall:>12.1f} {best.wall_time_s:>16.2f} "
              f"{best_cpu:>8.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
