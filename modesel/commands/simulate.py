"""`modesel simulate SCENE [--modeset MS.json] [--tmax T] [--dt DT] --out OUT.csv`

SCENE is a TOML scene or an ElastoDyn/OpenFAST main file. The CSV has a
`Time` column [s] and OpenFAST-named channels.
"""
from __future__ import annotations

from modesel.commands._common import atomic_write_text, load_modeset, positive_float


def register(sub):
    p = sub.add_parser("simulate", help="simulate a scene and write OpenFAST-named channels to CSV",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="TOML scene, ElastoDyn main file (.dat) or OpenFAST .fst")
    p.add_argument("--modeset", help="mode-set JSON overriding the scene's shapes")
    p.add_argument("--tmax", type=positive_float, help="simulated time [s] (default: the scene's)")
    p.add_argument("--dt", type=positive_float, help="output step [s] (default: the scene's)")
    p.add_argument("--out", required=True, help="output CSV file")
    p.set_defaults(func=run)


def run(args) -> int:
    from modesel.simulation.api import load_scene, simulate
    scene = load_scene(args.scene)
    result = simulate(scene, load_modeset(args.modeset), tmax=args.tmax, dt=args.dt)
    atomic_write_text(args.out, result.outputs.to_csv(index=False, float_format="%.9g"))
    print(f"{scene.name}: {result.n_dofs} DOFs ({', '.join(result.dof_names)}), "
          f"{result.simulated_time_s:g} s simulated in {result.wall_time_s:.3f} s "
          f"({result.speed:.0f}x real time, {result.method}) -> {args.out}")
    return 0
