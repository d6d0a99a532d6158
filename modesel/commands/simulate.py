"""`modesel simulate SCENE [--modeset MS.json] [--tmax T] [--dt DT] --out OUT.csv`

SCENE is a TOML scene or an ElastoDyn/OpenFAST main file. The CSV has a
`Time` column and OpenFAST-named channels, with a second header row of units
as OpenFAST text outputs (`Time,TTDspFA` then `(s),(m)`; read it with
`pandas.read_csv(OUT, header=[0, 1])`). For an OpenFAST case the CSV holds,
as OpenFAST's output does, the channels its OutLists name, in their order
and as typed (only those are computed: the strain gauges, tip accelerations
and the like cost an evaluation of the loads per output time);
`--all-channels` writes every channel modesel computes. The command says which DOFs and
effects ran and warns about settings that act on nothing (e.g. a wind with
neither aero nor tower drag on). A run longer than 2 s shows a progress line
on stderr (simulated time, x real time, ETA) when stderr is a terminal.
"""
from __future__ import annotations

import sys

from modesel.commands._common import atomic_write_text, collector_paused, load_modeset, positive_float


def register(sub):
    p = sub.add_parser("simulate", help="simulate a scene and write OpenFAST-named channels to CSV",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="TOML scene, ElastoDyn main file (.dat) or OpenFAST .fst")
    p.add_argument("--modeset", help="mode-set JSON overriding the scene's shapes")
    p.add_argument("--tmax", type=positive_float, help="simulated time [s] (default: the scene's)")
    p.add_argument("--dt", type=positive_float, help="output step [s] (default: the scene's)")
    p.add_argument("--out", required=True, help="output CSV file (second header row: units)")
    p.add_argument("--all-channels", action="store_true",
                   help="for an OpenFAST case: every channel modesel computes, not only those its OutLists name")
    p.add_argument("--no-stability-check", action="store_true",
                   help="simulate a statically unstable configuration instead of refusing it (as the scene's "
                        "[solver] stability_check = false; for .fst and ElastoDyn files)")
    p.set_defaults(func=run)


def run(args) -> int:
    with collector_paused() as started:
        return _run(args, started)


def _run(args, started) -> int:
    from modesel.files import columns_csv_text
    from modesel.model.effects import effects_in_scene
    from modesel.simulation.api import load_scene, simulate
    from modesel.simulation.progress import CompileProgress, SimulationProgress, speed_text
    scene = load_scene(args.scene)
    if args.no_stability_check:
        scene.solver = dict(scene.solver, stability_check=False)
    started()
    outlist = written_channels(scene, args.all_channels)
    line = SimulationProgress(f"{scene.name}: ")
    try:
        with CompileProgress():
            result = simulate(scene, load_modeset(args.modeset), tmax=args.tmax, dt=args.dt, progress=line,
                              channels=outlist)
    finally:
        line.close()
    units = dict(result.units, Time="s")
    columns = written_columns(result, outlist)
    atomic_write_text(args.out, columns_csv_text(columns, {c: units.get(c, "?") for c in columns}))
    on, flags, warnings = effects_in_scene(scene, result.dof_names)
    print(f"{scene.name}: {result.n_dofs} DOFs ({', '.join(result.dof_names)})")
    print(f"  effects evaluated: {', '.join(on) or 'none'}; system flags on: {', '.join(flags) or 'none'}")
    print(f"  {result.simulated_time_s:g} s simulated in {result.wall_time_s:.3g} s "
          f"({speed_text(result.simulated_time_s, result.wall_time_s)}, {result.method}) -> {args.out}")
    for text in scene.notes:
        print(f"  note: {text}")
    have = {c.lower() for c in result.columns}
    missing = [c for c in scene.out_list if c.lower() not in have]
    if missing:
        print(f"  note: {len(missing)} of the {len(scene.out_list)} channels the case's OutLists name are not "
              f"computed by modesel (not in {args.out}): {', '.join(missing)}")
    for text in warnings:
        print(f"modesel: warning: {scene.name}: {text}", file=sys.stderr)
    return 0


def written_channels(scene, all_channels: bool = False) -> list | None:
    """The channels `modesel simulate` computes and writes: an OpenFAST
    case's OutLists, each name once, in their order (None: every channel
    modesel computes, for a TOML scene or with --all-channels)."""
    return list(dict.fromkeys(scene.out_list)) if scene.out_list and not all_channels else None


def written_columns(result, channels) -> dict:
    """The result's columns the CSV holds: Time and `channels` where
    computed, in that order (all of them where `channels` is None)."""
    if channels is None:
        return result.columns
    return {c: result.columns[c] for c in ["Time", *channels] if c in result.columns}
