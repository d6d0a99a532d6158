"""`field_context(turbine, field)`: what a candidate family needs from a Turbine.

Tower fields carry the rotor-nacelle assembly (RNA) as a rigid tip body.
Its mass is nacelle + hub + blades (distributed mass and tip-brake masses)
+ yaw bearing. Its inertia is summed over those bodies about axes through
the tower top (parallel-axis theorem, I = sum I_cm + m (|r|^2 E - r r^T)),
in ElastoDyn axes (x downwind, y left, z up):

* tower_fa (deflection along x) uses I_yy, tower_ss (along y) uses I_xx,
  tower_torsion (yaw) uses I_zz.
* Positions follow ElastoDyn: nacelle CM at (NacCMxn, NacCMyn, NacCMzn);
  shaft axis c1 = (cos tilt, 0, sin tilt); rotor apex at
  (0, 0, Twr2Shft) + (OverHang - UndSling) c1; hub CM at apex + HubCM c1; blade-mass CM
  at apex + d c1 with d = int m r sin(precone) / int m (coning);
  yaw bearing at the tower top.
* Nacelle: ElastoDyn gives only NacYIner, about the yaw axis, so the
  inertia about its own vertical CM axis is NacYIner - m (x^2 + y^2).
  Approximation: the nacelle is a box about 2.5 times longer (x) than wide
  and high, so I_yy,cm = I_zz,cm and I_xx,cm = 0.25 I_zz,cm.
* Hub: spins freely on the shaft (generator DOF), so its inertia about the
  shaft axis does not follow a rotation of the tower top and is left out;
  its transverse inertia is HubIner/2 (E - c1 c1^T) (ElastoDyn gives only
  the axial value; thin-disc approximation), plus, for a two-blader, its
  inertia about the teeter axis averaged over a turn, Hubf2Iner/2 (E - c1 c1^T).
* Blades: a point mass at their centre of mass, without rotational inertia
  (the BModes/pyBmodes convention). The flexible blades (first flap/edge
  frequencies 0.7-1.1 Hz on the NREL 5-MW) do not follow a rotation of the
  tower top rigidly: attaching the rotor's transverse inertia (1.9e7 kg m^2)
  would put the 2nd tower fore-aft mode at 2.2 Hz instead of the ~2.9 Hz
  found by full-system analyses (Jonkman et al. 2009, table 9-1).
* Not modelled: the coupling between tip translation and rotation from the
  RNA centre-of-mass height (BModes/pyBmodes omit it for a cantilever tower
  too), drivetrain/generator inertia.

Blade fields get the blade beam, the tip-brake mass (blade 1), rotor_speed,
hub radius and precone (blade 1). elastodyn_coefficients come from
turbine.elastodyn_shapes[field].
"""
from __future__ import annotations

import numpy as np

from modesel.candidates.base import FieldContext
from modesel.errors import unknown_name
from modesel.modeset import FIELDS
from modesel.vocabulary import is_blade_field

NACELLE_ROLL_FRACTION = 0.25   # I_xx,cm / I_zz,cm of the nacelle (box, length ~2.5 x width)


def field_context(turbine, field: str, rotor_speed: float = 0.0) -> FieldContext:
    """FieldContext of `field` for a Turbine; `rotor_speed` [rad/s] for blades."""
    if field not in FIELDS:
        raise unknown_name("field", field, FIELDS, field="field")
    common = dict(field=field, gravity=turbine.gravity, source=turbine.source,
                  elastodyn_coefficients=tuple(tuple(c) for c in
                                               turbine.elastodyn_shapes.get(field, ())))
    if is_blade_field(field):
        return FieldContext(beam=turbine.blade, tip_mass=float(turbine.tip_mass[0]),
                            rotor_speed=float(rotor_speed), hub_radius=turbine.hub_radius,
                            precone=float(turbine.precone[0]), **common)
    mass, inertia = rna_mass_and_inertia(turbine)
    axis = {"tower_fa": 1, "tower_ss": 0, "tower_torsion": 2}[field]
    return FieldContext(beam=turbine.tower, tip_mass=mass, tip_inertia=float(inertia[axis, axis]),
                        **common)


def rna_mass_and_inertia(turbine):
    """(mass [kg], inertia tensor [kg m^2] about the tower top) of the RNA
    as described in the module docstring."""
    bodies = []   # (mass, position (3,), inertia about own CM (3, 3))
    x, y, z = turbine.nacelle_cm
    m_nac = turbine.nacelle_mass
    i_zz = max(turbine.nacelle_yaw_inertia - m_nac * (x * x + y * y), 0.0)
    bodies.append((m_nac, np.array([x, y, z]), np.diag([NACELLE_ROLL_FRACTION * i_zz, i_zz, i_zz])))
    bodies.append((turbine.yaw_bearing_mass, np.zeros(3), np.zeros((3, 3))))

    c1 = np.array([np.cos(turbine.shaft_tilt), 0.0, np.sin(turbine.shaft_tilt)])
    apex = np.array([0.0, 0.0, turbine.twr2shft]) + turbine.apex_overhang * c1
    transverse = np.eye(3) - np.outer(c1, c1)     # spin about c1 excluded
    bodies.append((turbine.hub_mass, apex + turbine.hub_cm * c1,
                   0.5 * (turbine.hub_inertia + turbine.hub_teeter_inertia) * transverse))

    blade = turbine.blade
    span = np.asarray(blade.span, dtype=float)
    r = turbine.hub_radius + span - span[0]
    m_blades = axial_moment = 0.0
    for k in range(turbine.num_blades):
        cone = turbine.precone[k] if k < len(turbine.precone) else turbine.precone[0]
        tip = turbine.tip_mass[k] if k < len(turbine.tip_mass) else turbine.tip_mass[0]
        m_blades += blade.total_mass + tip
        axial_moment += np.sin(cone) * (np.trapezoid(blade.mass * r, span) + tip * r[-1])
    offset = axial_moment / m_blades if m_blades > 0 else 0.0
    bodies.append((m_blades, apex + offset * c1, np.zeros((3, 3))))

    total = sum(m for m, _, _ in bodies)
    inertia = sum(i + m * (p @ p * np.eye(3) - np.outer(p, p)) for m, p, i in bodies)
    return float(total), inertia
