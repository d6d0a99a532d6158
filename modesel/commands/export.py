"""`modesel export MS.json --turbine DECK [--elastodyn OUTDIR] [--json OUT.json] [--weighting W] [--rpm R]`.

Export a chosen mode set for other simulators:

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
    default) or 'mass' (weighted by the mass per unit length).
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
    p.add_argument("--turbine", required=True, metavar="DECK",
                   help="ElastoDyn main file, .fst file, or 'nrel5mw'")
    p.add_argument("--elastodyn", metavar="OUTDIR", help="folder for the ElastoDyn files")
    p.add_argument("--json", metavar="OUT.json", help="JSON file with sampled shapes and shape integrals")
    p.add_argument("--weighting", default="uniform", help=f"fit weighting: {', '.join(WEIGHTINGS)}")
    p.add_argument("--rpm", default="0", help="rotor speed for blade fields [rpm] (default 0)")
    p.set_defaults(func=run)


def run(args) -> int:
    from modesel.export import export_modeset
    from modesel.modeset import ModeSet

    if args.elastodyn is None and args.json is None:
        raise ModeselError("nothing to export: give --elastodyn OUTDIR and/or --json OUT.json",
                           field="--elastodyn")
    if args.weighting not in WEIGHTINGS:
        raise ModeselError(f"unknown weighting '{args.weighting}'; valid: {', '.join(WEIGHTINGS)}",
                           field="--weighting")
    try:
        rpm = float(args.rpm)
    except ValueError:
        raise ModeselError(f"rotor speed must be a number, got {args.rpm!r}", field="--rpm") from None
    if not np.isfinite(rpm) or rpm < 0:
        raise ModeselError(f"rotor speed must be >= 0 rpm, got {rpm:g}", field="--rpm")
    modeset = ModeSet.from_json(args.modeset)
    report, data = export_modeset(modeset, args.turbine, elastodyn_dir=args.elastodyn,
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
