"""`modesel linearize SCENE [--modeset MS.json] [--rpm R1,R2,...] [--json] [--plot OUT.svg] [--no-aero]`

Natural frequencies [Hz], damping ratios and labels (the most
participating coordinate, unique per mode) of the scene linearised about its
initial state (zero elastic deflection); with --rpm the rotor turns at each
given constant speed (a Campbell sweep), the cyclic rotor modes are marked
forward or backward whirl and the symmetric ones collective; --plot draws
the Campbell diagram (frequency [Hz] versus rotor speed [rpm], 1P/3P/6P
lines) as a self-contained SVG. --no-aero leaves out the aerodynamic loads,
as the diagram in report.html does (at 0 rpm the BEM is not differentiable;
a warning says so when aerodynamics are on).
"""
from __future__ import annotations

import json
import math
import sys

from modesel.commands._common import atomic_write_text, load_modeset
from modesel.errors import ModeselError


def register(sub):
    p = sub.add_parser("linearize", help="natural frequencies, damping ratios and mode labels",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="TOML scene, ElastoDyn main file (.dat) or OpenFAST .fst")
    p.add_argument("--modeset", help="mode-set JSON overriding the scene's shapes")
    p.add_argument("--rpm", help="comma-separated rotor speeds [rpm] for a Campbell sweep")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument("--plot", metavar="OUT.svg", help="write the Campbell diagram (needs --rpm) as SVG")
    p.add_argument("--no-aero", action="store_true",
                   help="leave out the aerodynamic loads (wind, aero, tower_drag), as report.html's diagram")
    p.set_defaults(func=run)


def _parse_rpm(text):
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ModeselError(f"--rpm must be comma-separated numbers, got {text!r}", field="--rpm") from None
    if not values or any(not math.isfinite(v) or v < 0 for v in values):
        raise ModeselError(f"--rpm needs finite non-negative speeds, got {text!r}", field="--rpm")
    return values


def run(args) -> int:
    from modesel.simulation.api import linearize_scene, load_scene
    from modesel.study.report import aero_at_rest_warning, mode_kind, structural_scene
    scene = load_scene(args.scene)
    if args.no_aero:
        scene = structural_scene(scene)
    ms = load_modeset(args.modeset)
    if args.plot and not args.rpm:
        raise ModeselError("a Campbell diagram needs rotor speeds: add --rpm, e.g. --rpm 0,6,12.1",
                           field="--plot")
    speeds = _parse_rpm(args.rpm) if args.rpm else [None]
    if warning := aero_at_rest_warning(scene, speeds):
        print(f"modesel: warning: {scene.name}: {warning}", file=sys.stderr)
    results, sweep = [], []
    for rpm in speeds:
        modes, _ = linearize_scene(scene, ms, rpm=rpm)
        sweep.append((rpm, modes))
        results.append((rpm, [dict(m.as_dict(), kind=mode_kind(m)[1]) for m in modes]))
    if args.plot:
        from modesel.study.report import campbell_figure, standalone_svg
        svg = campbell_figure(sweep, f"{scene.name}" + (f" ({ms.label()})" if ms else ""))
        atomic_write_text(args.plot, standalone_svg(svg) + "\n")
    if args.json:
        if args.rpm:
            out = {"campbell": [{"rpm": rpm, "modes": modes} for rpm, modes in results]}
        else:
            out = {"modes": results[0][1]}
        print(json.dumps(out, indent=2))
        return 0
    for rpm, modes in results:
        if rpm is not None:
            print(f"rotor speed {rpm:g} rpm")
        print(f"{'#':>3} {'frequency [Hz]':>15} {'damping [-]':>12}  label")
        for i, m in enumerate(modes, 1):
            kind = f"  ({m['kind']})" if m["kind"] else ""
            print(f"{i:>3} {m['frequency_hz']:>15.5f} {m['damping_ratio']:>12.5f}  {m['label']}{kind}")
    if args.plot:
        print(f"Campbell diagram -> {args.plot}")
    return 0
