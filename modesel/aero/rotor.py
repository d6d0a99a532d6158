"""Steady performance of a rigid rotor: thrust, torque, power and their coefficients.

`steady_rotor` places the blades of an `AeroDynDeck` on a rigid, coned and
tilted rotor, builds the element inflow (V_n, V_t, skew) for several rotor
azimuths, solves all elements at once with `BemSolver` and integrates the
loads along the span with the trapezoidal rule (AeroDyn node loads, like its
line-to-point load mapping), averaging over the azimuths. Below a tip-speed ratio of 2 the inductions
are blended out as in AeroDyn (`bem` module doc, "Low tip-speed ratio").

Geometry (ElastoDyn axes and sign conventions, as the `Turbine` dataclass):
shaft axis x_s = (cos tilt, 0, sin tilt) with `shaft_tilt` = ShftTilt
(negative: upwind end up, -5 deg for the NREL 5-MW); blade axis
cos(precone) e_r + sin(precone) x_s with `precone` = PreCone (negative:
coned upwind, -2.5 deg); azimuth 0 = blade up, rotation positive about x_s.
Element at span s: distance from the axis r = (HubRad + s) cos(precone).
Normal inflow V_n = wind . e_n with e_n = -sin(precone) e_r + cos(precone) x_s,
V_t = Omega r - wind . e_theta; thrust = sum int f_n cos(precone) ds,
torque = sum int f_t r ds.

Defaults are a rotor without cone and tilt (precone = shaft_tilt = 0): the
AeroDyn deck does not hold them (they are ElastoDyn inputs); pass the
turbine's values to include them (see tests/test_aero.py for their effect on
the NREL 5-MW). Coefficients are normalised with the rotor radius
R = HubRad + last BlSpn (ElastoDyn TipRad; 62.9999 m for the NREL 5-MW deck) and
the hub-height speed:
TSR = Omega R / U, C_P = P / (1/2 rho pi R^2 U^3), C_T = T / (1/2 rho pi R^2 U^2),
C_Q = Q / (1/2 rho pi R^3 U^2).
"""
from __future__ import annotations

import numpy as np

from modesel.errors import ModeselError
from modesel.aero.bem import BemOptions, BemSolver
from modesel.aero.wind import Wind


def steady_rotor(wind_speed, rotor_speed, pitch, aero, *, hub_radius: float = 1.5,
                 num_blades: int = 3, precone: float = 0.0, shaft_tilt: float = 0.0,
                 yaw_error: float = 0.0, n_azimuth: int | None = None, span=None,
                 shear_exponent: float = 0.0, hub_height: float = 90.0,
                 options: BemOptions | None = None,
                 air_density: float | None = None) -> dict:
    """Steady loads of a rigid rotor.

    wind_speed : hub-height wind speed U [m/s] (> 0).
    rotor_speed : Omega [rad/s].  pitch : collective blade pitch [rad].
    aero : `AeroDynDeck` (blade, air density and model options).
    hub_radius : HubRad [m]; num_blades : NumBl.
    precone, shaft_tilt : PreCone, ShftTilt [rad] in ElastoDyn signs.
    yaw_error : wind direction relative to the rotor, from x towards y [rad].
    n_azimuth : rotor positions averaged over one blade passage (default 1
        for an axisymmetric case, else 8).
    span : element stations [m from the blade root] (default: AeroDyn nodes).
    shear_exponent : power-law shear (`Wind`) about the hub height
        `hub_height` [m] (rotor apex height above ground).
    options, air_density : override the deck's BEM options / density.

    Returns dict: thrust [N], torque [N m], power [W], cp, ct, cq, tsr,
    and `elements` (the `ElementLoads`, shape (n_azimuth, B, n_span)).
    """
    U = float(wind_speed)
    if not U > 0:
        raise ModeselError(f"wind speed must be > 0, got {wind_speed}", field="wind_speed")
    blade = aero.blade
    rho = aero.air_density if air_density is None else float(air_density)
    options = options or BemOptions.from_deck(aero)
    span = blade.span if span is None else np.asarray(span, float)
    axisymmetric = shaft_tilt == 0 and yaw_error == 0 and shear_exponent == 0
    if n_azimuth is None:
        n_azimuth = 1 if axisymmetric else 8
    solver = BemSolver.from_blade(blade, span, num_blades=num_blades, hub_radius=hub_radius,
                                  precone=precone, air_density=rho, options=options)
    # rotor positions: (n_azimuth, B, 1)
    psi = (np.arange(n_azimuth)[:, None] / n_azimuth + np.arange(num_blades)[None, :]) \
        * (2.0 * np.pi / num_blades)
    psi = psi[:, :, None]
    cb, sb = np.cos(precone), np.sin(precone)
    ct_, st_ = np.cos(shaft_tilt), np.sin(shaft_tilt)
    radius = hub_radius + span                            # along the coned blade
    r = radius * cb                                       # from the shaft axis
    # element height above ground (rotor apex at hub_height)
    z = hub_height + radius * (cb * np.cos(psi) * ct_ + sb * st_)
    u = Wind(U, shear_exponent, reference_height=hub_height).velocity(z)
    # wind components in the shaft frame
    vx = u * np.cos(yaw_error) * ct_
    vy = u * np.sin(yaw_error)
    vz = -u * np.cos(yaw_error) * st_
    v_radial = np.cos(psi) * vz - np.sin(psi) * vy         # wind . e_r
    v_theta = -np.sin(psi) * vz - np.cos(psi) * vy         # wind . e_theta
    v_n = -sb * v_radial + cb * vx
    v_t = rotor_speed * r - v_theta
    plane = np.hypot(vy, vz)
    skew = np.arctan2(plane, vx)
    cos_rel = np.where(plane > 0, v_radial / np.where(plane > 0, plane, 1.0), 1.0)
    skew_azimuth = np.arccos(np.clip(cos_rel, -1.0, 1.0))
    # AeroDyn's TSR for the low-TSR blend (`bem` module doc): largest r over the disk-averaged wind along x_s
    v_dot_x = float(np.mean(np.broadcast_to(vx, v_n.shape)))
    loads = solver.solve(r, v_n, v_t, pitch, skew, skew_azimuth,
                         tsr=rotor_speed * float(np.max(r)) / v_dot_x if v_dot_x != 0.0 else 0.0)
    thrust = np.trapezoid(loads.f_n * cb, span, axis=-1).sum(axis=-1).mean()
    torque = np.trapezoid(loads.f_t * r, span, axis=-1).sum(axis=-1).mean()
    R = hub_radius + blade.span[-1]
    q_area = 0.5 * rho * np.pi * R * R * U * U
    power = torque * rotor_speed
    return dict(thrust=float(thrust), torque=float(torque), power=float(power),
                ct=float(thrust / q_area), cq=float(torque / (q_area * R)),
                cp=float(power / (q_area * U)), tsr=float(rotor_speed * R / U), elements=loads)
