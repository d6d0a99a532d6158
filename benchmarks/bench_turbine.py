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
"integration" is `SimulationResult.wall_time_s` (without the channels).

    python3 benchmarks/bench_turbine.py [--tmax 60] [--repeat 3]
"""
from __future__ import annotations

import argparse
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
    args = p.parse_args(argv)
    scene = load_scene(SCENE)
    print(f"{'case':<26} {'DOFs':>5} {'method':>7} {'RHS':>7} {'wall best [s]':>14} {'median [s]':>11} "
          f"{'x real time':>12} {'integration [s]':>16}")
    for name, modeset in cases():
        simulate(scene, modeset, tmax=1.0)                       # load compiled code
        runs = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            result = simulate(scene, modeset, tmax=args.tmax)
            runs.append((time.perf_counter() - start, result))
        walls = [w for w, _ in runs]
        best_wall, best = min(runs, key=lambda r: r[0])
        print(f"{name:<26} {best.n_dofs:>5} {best.method:>7} {best.n_rhs:>7} {best_wall:>14.2f} "
              f"{statistics.median(walls):>11.2f} {args.tmax / best_wall:>12.1f} {best.wall_time_s:>16.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
