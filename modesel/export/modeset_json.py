"""JSON export of a mode set: sampled shapes and their shape integrals.

For simulators that take tabulated shapes (or SID-style shape integrals)
rather than ElastoDyn polynomials. The file holds

- `modeset`: the mode set as given (`modesel.modeset.ModeSet.to_dict`);
- `turbine`: deck path, gravity [m/s^2], rotor speed used for blades [rpm];
- `fields.<field>`: family, count, parameters (defaults filled in), beam
  length L [m], top mass [kg], stations `x` (normalised span s/L, 0 at the
  root) and per mode `phi` (tip value 1), `dphi` = dphi/dx, `ddphi` =
  d2phi/dx2 (divide by L and L^2 for slopes [1/m] and curvatures [1/m^2]);
- `fields.<field>.integrals`: every attribute of
  `modesel.multibody.shape_integrals.ShapeIntegrals` (first paper, App.
  A-C: mass, stiffness, damping, geometric stiffness, spin softening, tip
  deflection and slope, uncoupled frequencies [Hz], SID terms), in SI units
  per unit modal coordinate = tip value of the raw shape. The raw basis is
  kept (no orthonormalisation) so the matrices belong to the exported shapes;
  `condition_number` tells how independent they are.

Towers carry the rotor-nacelle assembly as top mass (eq. 33); blades are
evaluated at `rpm` (default 0, parked). ElastoDyn's modal stiffness tuners
are applied to the `elastodyn` family only (they belong to the deck's modes).
"""
from __future__ import annotations

import dataclasses
import json

import numpy as np

from modesel.export.common import stations, write_text
from modesel.multibody.shape_integrals import ILL_CONDITIONED, shape_integrals
from modesel.vocabulary import TOWER_FIELDS

FORMAT = "modesel-modeset-export/1"


def jsonable(value):
    """numpy arrays/scalars, dicts, tuples -> plain JSON types."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value)
    return value


def field_record(fs, turbine) -> dict:
    """Sampled shapes and shape integrals of one field (FieldShapes)."""
    x = stations()
    sampled = fs.sample(x)
    ctx = fs.context
    beam = turbine.tower if fs.field in TOWER_FIELDS else turbine.blade
    tuners = beam.stiffness_tuners.get(fs.field) if fs.family == "elastodyn" else None
    integrals = shape_integrals(beam, fs.sample, top_mass=ctx.tip_mass, gravity=turbine.gravity,
                                rotor_speed=ctx.rotor_speed, precone=ctx.precone,
                                stiffness_tuners=tuners, orthonormalise=False)
    notes = list(integrals.notes)
    if integrals.condition_number > ILL_CONDITIONED:
        notes.append(f"shapes nearly dependent (mass-matrix condition number "
                     f"{integrals.condition_number:.3g}); matrices kept in the raw basis.")
    record = {
        "family": fs.family, "count": fs.count, "params": dict(sampled.params),
        "length": beam.length, "top_mass": ctx.tip_mass, "x": x,
        "modes": [{"mode": k + 1, "phi": sampled.phi[k], "dphi": sampled.dphi[k], "ddphi": sampled.ddphi[k]}
                  for k in range(sampled.count)],
        "integrals": {f.name: getattr(integrals, f.name) for f in dataclasses.fields(integrals)},
    }
    record["integrals"]["notes"] = notes
    return jsonable(record)


def modeset_record(modeset, shapes: dict, turbine, *, rpm: float = 0.0) -> dict:
    """The JSON object described in the module docstring."""
    return {
        "format": FORMAT,
        "modeset": modeset.to_dict(),
        "turbine": {"deck": turbine.source, "gravity": turbine.gravity, "rotor_speed_rpm": float(rpm)},
        "conventions": {
            "x": "normalised span s/L from the root, L = fields.<field>.length [m]",
            "phi": "shape, tip value 1; dphi = dphi/dx, ddphi = d2phi/dx2",
            "integrals": "SI units per unit modal coordinate (tip value of the shape); "
                         "ElastoDyn axes (x downwind, y left, z up); tower_ss shapes displace along -y",
        },
        "fields": {name: field_record(fs, turbine) for name, fs in shapes.items()},
    }


def write_modeset_json(modeset, shapes: dict, turbine, path, *, rpm: float = 0.0) -> dict:
    """Write `modeset_record(...)` to `path`; return it."""
    data = modeset_record(modeset, shapes, turbine, rpm=rpm)
    write_text(path, json.dumps(data, indent=1) + "\n")
    return data
