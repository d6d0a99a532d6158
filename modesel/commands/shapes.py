"""`modesel shapes TURBINE --field F --family NAME --count N [--param K=V ...] [--rpm R] [--json]`.

Generalised mass, stiffness, damping and geometric stiffness matrices, tip
deflection and slope, uncoupled frequencies and the mass-matrix condition
number of `count` modes of `family` for one field of a turbine (an
ElastoDyn/.fst deck or the built-in `nrel5mw`). Towers carry the
rotor-nacelle assembly as top mass (eq. 33); blades are evaluated at
--rpm (default 0, parked). ElastoDyn modal stiffness tuners are applied to
the `elastodyn` family only (they belong to the deck's own modes).
"""
from __future__ import annotations

import json

import numpy as np

from modesel.candidates import get_family
from modesel.candidates.context import field_context
from modesel.errors import ModeselError, unknown_name
from modesel.modeset import FIELDS
from modesel.turbine.elastodyn import load_turbine
from modesel.multibody.shape_integrals import shape_integrals
from modesel.vocabulary import TOWER_FIELDS, is_blade_field

FULL_MATRICES_UP_TO = 6   # the text table prints full matrices up to this many modes
JSON_MATRICES = ("gravity_top_mass", "gravity_self_weight", "centrifugal_per_omega2", "gravity_axial_per_g")


def register(subparsers):
    p = subparsers.add_parser("shapes", help="shape integrals of a family of assumed modes",
                              description=__doc__.splitlines()[0])
    p.add_argument("turbine", metavar="TURBINE", help="ElastoDyn main file, .fst file, or 'nrel5mw'")
    p.add_argument("--field", required=True, help=f"one of {', '.join(FIELDS)}")
    p.add_argument("--family", required=True, help="candidate family (see `modesel candidates`)")
    p.add_argument("--count", required=True, help="number of modes (>= 1)")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="shape parameter of the family (repeatable)")
    p.add_argument("--rpm", default="0", help="rotor speed for blade fields [rpm] (default 0)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def parse_params(items) -> dict:
    """['k=v', ...] -> {k: float(v)}."""
    params = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        if not sep or not key.strip():
            raise ModeselError(f"expected KEY=VALUE, got {item!r}", field="--param")
        try:
            params[key.strip()] = float(value)
        except ValueError:
            raise ModeselError(f"parameter '{key.strip()}' must be a number, got {value!r}",
                               field="--param") from None
    return params


def compute(turbine_name, field: str, family: str, count, params=None, rpm=0.0):
    """(ShapeIntegrals, turbine, context, full shape parameters) for the command's inputs."""
    if field not in FIELDS:
        raise unknown_name("field", field, FIELDS, field="--field")
    try:
        count = int(str(count))
    except ValueError:
        raise ModeselError(f"count must be an integer >= 1, got {count!r}", field="--count") from None
    if count < 1:
        raise ModeselError(f"count must be an integer >= 1, got {count}", field="--count")
    try:
        rpm = float(rpm)
    except ValueError:
        raise ModeselError(f"rotor speed must be a number, got {rpm!r}", field="--rpm") from None
    if not np.isfinite(rpm) or rpm < 0:
        raise ModeselError(f"rotor speed must be >= 0 rpm, got {rpm:g}", field="--rpm")
    fam = get_family(family)
    turbine = load_turbine(turbine_name)
    context = field_context(turbine, field, rotor_speed=rpm * np.pi / 30.0)
    params = dict(params or {})
    checked = fam.shapes(np.linspace(0.0, 1.0, 5), count, context, **params)   # validate first
    beam = turbine.tower if field in TOWER_FIELDS else turbine.blade
    tuners = beam.stiffness_tuners.get(field) if family == "elastodyn" else None
    result = shape_integrals(
        beam, lambda x: fam.shapes(x, count, context, **params),
        top_mass=context.tip_mass, gravity=turbine.gravity, rotor_speed=context.rotor_speed,
        precone=context.precone, stiffness_tuners=tuners)
    return result, turbine, context, dict(checked.params)


def frequencies_with_top_mass(result, top_mass: float):
    """Uncoupled frequencies [Hz] of a tower bending field with the top mass
    as a point mass at the tip (its inertia added: M + m_top d d^T with d the
    tip deflections; its rotary inertia left out), or None for other fields
    or without top mass. `result.frequencies_hz` leave the top-mass inertia
    out (only its weight, through the geometric stiffness)."""
    import scipy.linalg
    if top_mass <= 0 or result.field not in ("tower_fa", "tower_ss"):
        return None
    d = np.asarray(result.tip_deflection, float)
    stiffness = (np.asarray(result.stiffness) + result.geometric_stiffness["gravity_top_mass"]
                 + result.geometric_stiffness["gravity_self_weight"])
    eig = scipy.linalg.eigh(stiffness, np.asarray(result.mass) + top_mass * np.outer(d, d), eigvals_only=True)
    return np.sign(eig) * np.sqrt(np.abs(eig)) / (2.0 * np.pi)


def boundary_conditions(result, top_mass: float) -> str:
    """What the printed frequencies assume, in words."""
    if result.field in TOWER_FIELDS:
        text = "tower clamped at the base, free at the top"
        if top_mass > 0:
            text += (f"; 'freq' leaves the {top_mass:.6g} kg top mass out of the inertia (only its weight "
                     "acts, through the geometric stiffness)")
            if result.field != "tower_torsion":
                text += "; 'freq+top' adds it as a point mass at the tip (no rotary inertia)"
        return text
    return "blade clamped at the root, free at the tip, centrifugal stiffening at the given rotor speed"


def as_dict(result, context, rpm: float, params=None) -> dict:
    """The JSON object printed by `modesel shapes --json`."""
    def listed(a):
        return np.asarray(a, dtype=float).tolist()

    return {
        "field": result.field, "family": result.family, "count": result.count,
        "params": dict(params or {}),
        "rotor_speed_rpm": rpm, "top_mass": context.tip_mass, "length": result.length,
        "mass": listed(result.mass), "stiffness": listed(result.stiffness),
        "damping": listed(result.damping),
        "geometric_stiffness": {k: listed(result.geometric_stiffness[k]) for k in JSON_MATRICES},
        "spin_softening_per_omega2": listed(result.spin_softening_per_omega2),
        "tip_deflection": listed(result.tip_deflection), "tip_slope": listed(result.tip_slope),
        "frequencies_hz": listed(result.frequencies_hz),
        "frequencies_with_top_mass_hz": (None if (f := frequencies_with_top_mass(result, context.tip_mass)) is None
                                         else listed(f)),
        "boundary_conditions": boundary_conditions(result, context.tip_mass),
        "condition_number": float(result.condition_number),
        "orthonormalised": bool(result.orthonormalised),
        "transform": listed(result.transform),
        "notes": list(result.notes),
    }


def run(args) -> int:
    params = parse_params(args.param)
    result, turbine, context, params = compute(args.turbine, args.field, args.family, args.count,
                                               params, args.rpm)
    rpm = float(args.rpm)
    if args.json:
        print(json.dumps(as_dict(result, context, rpm, params)))
        return 0
    print(f"{result.field}: {result.count} x {result.family} on {turbine.source}")
    print(f"  length {result.length:.4g} m, top mass {context.tip_mass:.6g} kg, gravity "
          f"{turbine.gravity:g} m/s^2" + (f", rotor speed {rpm:g} rpm" if is_blade_field(result.field) else ""))
    print(f"  mass-matrix condition number {result.condition_number:.3e}"
          + (" (basis mass-orthonormalised)" if result.orthonormalised else ""))
    with_top = frequencies_with_top_mass(result, context.tip_mass)
    print(f"  uncoupled frequencies: {boundary_conditions(result, context.tip_mass)}")
    print(f"  {'mode':>4} {'freq [Hz]':>11}" + (f" {'freq+top [Hz]':>13}" if with_top is not None else "")
          + f" {'M_ii [kg]':>12} {'K_ii [N/m]':>12} {'tip [-]':>9} {'slope[1/m]':>11}")
    for i in range(result.count):
        print(f"  {i + 1:>4} {result.frequencies_hz[i]:>11.5g}"
              + (f" {with_top[i]:>13.5g}" if with_top is not None else "")
              + f" {result.mass[i, i]:>12.5g} "
              f"{result.stiffness[i, i]:>12.5g} {result.tip_deflection[i]:>9.4g} {result.tip_slope[i]:>11.5g}")
    if result.count > FULL_MATRICES_UP_TO:
        print(f"  (matrices of more than {FULL_MATRICES_UP_TO} modes: use --json)")
        for note in result.notes:
            print(f"  note: {note}")
        return 0
    blocks = [("mass M_e", result.mass), ("stiffness K_e", result.stiffness), ("damping D_e", result.damping)]
    blocks += [(f"geometric {k}", result.geometric_stiffness[k]) for k in JSON_MATRICES]
    with np.printoptions(precision=5, linewidth=110):
        for title, matrix in blocks:
            print(f"  {title}:")
            for line in str(np.asarray(matrix)).splitlines():
                print(f"    {line}")
    for note in result.notes:
        print(f"  note: {note}")
    return 0
