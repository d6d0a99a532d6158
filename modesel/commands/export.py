"""`modesel export MS.json [--turbine DECK] [--elastodyn OUTDIR] [--json OUT.json] [--case CASE.fst --openfast OUTDIR [--tmax T]] [--weighting W] [--rpm R]`.

Export a chosen mode set for other simulators. The turbine is `--turbine`,
else the `--case`, else the first scene of the study that wrote MS.json
(`best_modeset.json` names its scenes):

--case CASE.fst --openfast OUTDIR  a complete OpenFAST case running the set:
    CASE.fst and every file it names copied into OUTDIR (same relative
    layout), its ElastoDyn files replaced by fits of the set's shapes (blade
    shapes at the case's initial rotor speed, as `modesel simulate` uses
    them); `--tmax T` sets TMax [s]. A set ElastoDyn cannot hold is refused.

--elastodyn OUTDIR  ElastoDyn main, tower and blade files (written by
    openfast-io) whose mode-shape polynomials are constrained sixth-order
    fits of the mode set's shapes (coefficients of x^2..x^6 summing to 1,
    first paper eq. 46), DOF flags set to match; per-mode fit residuals are
    printed and written to OUTDIR/<deck>_modesel_fits.json. ElastoDyn holds
    at most 2 tower fore-aft, 2 side-side, 2 flap and 1 edge modes and no
    tower torsion; the report warns about anything left out.
--json OUT.json  the mode set, its shapes sampled on the normalised span
    (phi, dphi/dx, d2phi/dx2) and their shape integrals (mass, stiffness,
    damping, geometric stiffness, tip slope, frequencies, SID terms).
--weighting  least-squares weight of the fits: 'uniform' (L2 over the span,
    default), 'mass' (weighted by the mass per unit length) or 'stiffness'
    (curvature error weighted by the bending stiffness: keeps ElastoDyn's
    frequency of the mode best; the report prints it for shape and fit).
--rpm  rotor speed for blade fields [rpm] (default 0, parked).
"""
from __future__ import annotations

import numpy as np

from modesel.errors import ModeselError
from modesel.export.polyfit import WEIGHTINGS


def register(subparsers):
    p = subparsers.add_parser("export", help="export a mode set as ElastoDyn files and/or JSON",
                              description=__doc__.splitlines()[0])
    p.add_argument("modeset", metavar="MS.json", help="mode-set JSON file")
    p.add_argument("--turbine", metavar="DECK",
                   help="ElastoDyn main file, .fst file, or 'nrel5mw' (default: --case, or the study's "
                        "first scene named in MS.json)")
    p.add_argument("--case", metavar="CASE.fst", help="OpenFAST case to run the set in (with --openfast)")
    p.add_argument("--openfast", metavar="OUTDIR", help="folder for the complete OpenFAST case")
    p.add_argument("--tmax", metavar="T", help="TMax [s] of the exported OpenFAST case (default: the case's)")
    p.add_argument("--elastodyn", metavar="OUTDIR", help="folder for the ElastoDyn files")
    p.add_argument("--json", metavar="OUT.json", help="JSON file with sampled shapes and shape integrals")
    p.add_argument("--weighting", default="uniform", help=f"fit weighting: {', '.join(WEIGHTINGS)}")
    p.add_argument("--rpm", default="0", help="rotor speed for blade fields [rpm] (default 0)")
    p.set_defaults(func=run)


def _number(text, name, low=0.0):
    try:
        value = float(text)
    except ValueError:
        raise ModeselError(f"must be a number, got {text!r}", field=name) from None
    if not np.isfinite(value) or value < low:
        raise ModeselError(f"must be >= {low:g}, got {value:g}", field=name)
    return value


def study_turbine(path) -> str | None:
    """The deck of the first scene named by a best_modeset.json (key 'scenes'), or None."""
    import json
    from pathlib import Path

    from modesel.simulation.api import load_scene
    try:
        scenes = json.loads(Path(path).read_text()).get("scenes") or []
    except (OSError, ValueError, AttributeError):
        return None
    if not scenes:
        return None
    scene = Path(path).parent / scenes[0]
    turbine = load_scene(scene).turbine
    return getattr(turbine, "source", None) or str(scene)


def run(args) -> int:
    from modesel.export import export_modeset
    from modesel.modeset import ModeSet

    if args.elastodyn is None and args.json is None and args.openfast is None:
        raise ModeselError("nothing to export: give --elastodyn OUTDIR, --json OUT.json and/or "
                           "--case CASE.fst --openfast OUTDIR", field="--elastodyn")
    if (args.openfast is None) != (args.case is None):
        raise ModeselError("--openfast OUTDIR and --case CASE.fst go together",
                           field="--case" if args.case is None else "--openfast")
    if args.weighting not in WEIGHTINGS:
        raise ModeselError(f"unknown weighting '{args.weighting}'; valid: {', '.join(WEIGHTINGS)}",
                           field="--weighting")
    rpm = _number(args.rpm, "--rpm")
    tmax = None if args.tmax is None else _number(args.tmax, "--tmax", low=1e-9)
    modeset = ModeSet.from_json(args.modeset)
    if args.openfast is not None:
        from modesel.export.openfast_case import export_openfast_case
        fst, report = export_openfast_case(modeset, args.case, args.openfast, tmax=tmax,
                                           weighting=args.weighting, source=args.modeset)
        print(f"OpenFAST case written: {fst} ({len(report.files)} files)")
        print("\n".join(report.lines()[1:]))
    turbine = args.turbine or args.case or study_turbine(args.modeset)
    if args.elastodyn is None and args.json is None:
        return 0
    if turbine is None:
        raise ModeselError("no turbine: give --turbine DECK (the mode-set file names no study scene)",
                           field="--turbine")
    report, data = export_modeset(modeset, turbine, elastodyn_dir=args.elastodyn,
                                  json_path=args.json, weighting=args.weighting, rpm=rpm,
                                  source=args.modeset)
    if report is not None:
        print("\n".join(report.lines()))
    if data is not None:
        print(f"JSON with sampled shapes and shape integrals written to {args.json}")
        for name, record in data["fields"].items():
            freqs = ", ".join(f"{f:.4g}" for f in record["integrals"]["frequencies_hz"])
            print(f"  {name:<13} {record['family']}:{record['count']}  uncoupled beam frequencies [Hz]: {freqs}")
        print("  (beam mass only; a top mass enters through geometric stiffness, eq. 33)")
    return 0
