"""Turbine template: builds the body tree of a horizontal-axis wind turbine
(first paper Fig. 4 and 7; second paper section 2, eq. 11-31) from a
`Turbine`, a `ModeSet` and the DOFs a scene frees.

Bodies (parents first): [platform] -> tower (flexible: fore-aft, side-side,
torsion modes) -> nacelle (carried by the tower-top elastic translation,
shortening and rotation) -> hub (shaft tilt, overhang, rotor azimuth
GeAz + DrTr) -> blades 1..3 (flexible: flap, edge; precone, pitch) and the
generator (azimuth GBRatio * GeAz about the shaft).

Coordinate names: tower TFA1.., TSS1.., TTor1..; blades B{b}F1.., B{b}E1..;
rigid: GeAz (generator azimuth, LSS side), DrTr (drivetrain twist), Yaw,
PtfmSurge, PtfmPitch. Output channels are Q_<name> like OpenFAST.
A field absent from the ModeSet has no DOF (rigid in that direction), so a
scene without blade DOFs allocates no blade states.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from modesel.candidates.base import mode_shapes
from modesel.modeset import ModeSet
from modesel.surrogate_sim.bodies import FlexibleBody, Joint, RigidBody, Rotation
from modesel.surrogate_sim.equations import elementary_rotation
from modesel.surrogate_sim.flexible_beam import build_flexible_body, evaluate_field, tip_joint
from modesel.surrogate_sim.system import Prescribed, System

FIELD_PREFIX = {"tower_fa": "TFA", "tower_ss": "TSS", "tower_torsion": "TTor",
                "blade_flap": "F", "blade_edge": "E"}
RIGID_DOFS = ("GeAz", "DrTr", "Yaw", "PtfmSurge", "PtfmPitch")


def field_dofs(field_name: str, count: int, blade: int | None = None) -> tuple:
    p = FIELD_PREFIX[field_name]
    if blade is not None:
        return tuple(f"B{blade}{p}{i + 1}" for i in range(count))
    return tuple(f"{p}{i + 1}" for i in range(count))


@dataclass
class TurbineModel:
    """The System plus what outputs need to know (field DOFs, tip data)."""

    system: System
    turbine: object
    modeset: ModeSet
    field_dofs: dict = field(default_factory=dict)     # field -> dofs (blades: list per blade)
    tips: dict = field(default_factory=dict)            # body name -> tip dict
    shapes: dict = field(default_factory=dict)          # field -> ShapeSet (at nodes)


def _shapes_for(turbine, fld, modes, rotor_speed):
    from modesel.candidates.context import field_context
    ctx = field_context(turbine, fld, rotor_speed=rotor_speed)
    return lambda x: mode_shapes(fld, modes.family, modes.count, ctx, x=x, **modes.params)


def build_turbine(turbine, modeset: ModeSet, *, free=(), fixed=None, prescribed=None,
                  gravity: bool = True, geometric_stiffening: bool = True,
                  rotor_speed_for_shapes: float = 0.0, pitch: float = 0.0,
                  include_blades: bool = True, min_nodes: int = 40) -> TurbineModel:
    """Body tree of `turbine` with the elastic fields of `modeset`.

    free: rigid DOFs integrated in time (subset of RIGID_DOFS); elastic DOFs
    of every field in `modeset` are free. fixed: {name: value}; prescribed:
    {name: Prescribed}. pitch [rad] collective (fixed). Units SI.
    """
    fixed = dict(fixed or {})
    prescribed = dict(prescribed or {})
    t = turbine
    bodies = []
    fdofs = {}
    tips = {}
    shapes = {}
    fine_n = 801

    # ---- platform (only when a platform DOF is used)
    uses_platform = any(d in ("PtfmSurge", "PtfmPitch") for d in list(free) + list(fixed) + list(prescribed))
    tower_parent = None
    tower_offset = np.array([0.0, 0.0, t.tower_base_height])
    if uses_platform:
        pj = Joint(None, np.array([0.0, 0.0, t.platform_ref_z]), translation={"PtfmSurge": np.array([1.0, 0, 0])},
                   rotations=[Rotation(1, {"PtfmPitch": 1.0})])
        cm = np.array(t.platform_cm, float) - np.array([0.0, 0.0, t.platform_ref_z])
        bodies.append(RigidBody("platform", pj, t.platform_mass, cm, np.diag(t.platform_inertia)))
        tower_parent = "platform"
        tower_offset = np.array([0.0, 0.0, t.tower_base_height - t.platform_ref_z])

    # ---- tower
    tower_fields = []
    for fld in ("tower_fa", "tower_ss", "tower_torsion"):
        if fld in modeset:
            modes = modeset[fld]
            dofs = field_dofs(fld, modes.count)
            fdofs[fld] = dofs
            from modesel.surrogate_sim.flexible_beam import beam_quadrature
            s_nodes, _ = beam_quadrature(t.tower.span, min_nodes)
            fine_s = np.linspace(0, t.tower.length, fine_n)
            fn = _shapes_for(t, fld, modes, 0.0)
            tower_fields.append(evaluate_field(fld, dofs, fn, s_nodes, t.tower.length, fine_s,
                                               t.tower.damping_ratio.get(fld, ()),
                                               getattr(t.tower, "stiffness_tuners", {}).get(fld, ())))
            shapes[fld] = fn
    tower, ttip = build_flexible_body("tower", Joint(tower_parent, tower_offset), t.tower, tower_fields,
                                      shortening=geometric_stiffening, min_nodes=min_nodes)
    bodies.append(tower)
    tips["tower"] = ttip

    # ---- nacelle (yaw bearing + nacelle), ElastoDyn: only the yaw inertia
    yaw = [Rotation(2, {"Yaw": 1.0})]
    nj = tip_joint("tower", ttip, extra_rotations=yaw)
    ncm = np.array(t.nacelle_cm, float)
    mn = t.nacelle_mass + t.yaw_bearing_mass
    cm = ncm * t.nacelle_mass / mn if mn > 0 else np.zeros(3)
    Izz = max(t.nacelle_yaw_inertia - t.nacelle_mass * (ncm[0] ** 2 + ncm[1] ** 2), 0.0)
    Izz -= t.yaw_bearing_mass * 0.0
    bodies.append(RigidBody("nacelle", nj, mn, cm, np.diag([0.0, 0.0, Izz])))

    # ---- shaft geometry: x_s along the (tilted) shaft, downwind
    tilt = elementary_rotation(1, -t.shaft_tilt)
    apex = np.array([0.0, 0.0, t.twr2shft]) + t.overhang * tilt[:, 0]
    rotor_angle = {"GeAz": 1.0, "DrTr": 1.0}
    hj = Joint("nacelle", apex, tilt, rotations=[Rotation(0, rotor_angle)])
    bodies.append(RigidBody("hub", hj, t.hub_mass, np.array([t.hub_cm, 0.0, 0.0]),
                            np.diag([t.hub_inertia, 0.0, 0.0])))
    gj = Joint("nacelle", apex, tilt, rotations=[Rotation(0, {"GeAz": t.gearbox_ratio})])
    bodies.append(RigidBody("generator", gj, 0.0, np.zeros(3), np.diag([t.generator_inertia, 0.0, 0.0])))

    # ---- blades
    if include_blades:
        blade_fields_spec = [(f, modeset[f]) for f in ("blade_flap", "blade_edge") if f in modeset]
        from modesel.surrogate_sim.flexible_beam import beam_quadrature
        s_nodes, _ = beam_quadrature(t.blade.span, min_nodes)
        fine_s = np.linspace(0, t.blade.length, fine_n)
        evaluated = {}
        for fld, modes in blade_fields_spec:
            fn = _shapes_for(t, fld, modes, rotor_speed_for_shapes)
            evaluated[fld] = (fn(s_nodes / t.blade.length), fn(np.array([1.0])), fn(fine_s / t.blade.length))
            shapes[fld] = fn
        for b in range(1, t.num_blades + 1):
            psi = 2 * np.pi * (b - 1) / t.num_blades
            pre = (elementary_rotation(0, psi) @ elementary_rotation(1, t.precone[b - 1])
                   @ elementary_rotation(2, -pitch))
            bj = Joint("hub", np.zeros(3), pre)
            flds = []
            for fld, modes in blade_fields_spec:
                dofs = field_dofs(fld, modes.count, blade=b)
                fdofs.setdefault(fld, []).append(dofs)
                at_nodes, at_tip, fine = evaluated[fld]
                L = t.blade.length
                from modesel.surrogate_sim.flexible_beam import FieldShapes
                flds.append(FieldShapes(fld, dofs, at_nodes.phi, at_nodes.dphi / L, at_nodes.ddphi / L**2,
                                        at_tip.phi[:, 0], at_tip.dphi[:, 0] / L, fine.dphi / L,
                                        tuple(t.blade.damping_ratio.get(fld, ())),
                                        tuple(getattr(t.blade, "stiffness_tuners", {}).get(fld, ()))))
            body, btip = build_flexible_body(f"blade{b}", bj, t.blade, flds,
                                             shortening=geometric_stiffening, min_nodes=min_nodes)
            if t.tip_mass[b - 1] > 0:
                body.nodes = np.vstack([body.nodes, [0.0, 0.0, btip["length"]]])
                body.node_mass = np.append(body.node_mass, t.tip_mass[b - 1])
                tipPhi = np.zeros((1, 3, body.n_elastic))
                for i, d in enumerate(body.dofs):
                    tipPhi[0, :, i] = btip["displacement"].get(d, np.zeros(3))
                body.shapes = np.concatenate([body.shapes, tipPhi], axis=0)
                if body.shortening is not None:
                    body.shortening = np.concatenate([body.shortening, btip["shortening"][1][None]], axis=0)
            bodies.append(body)
            tips[f"blade{b}"] = btip

    elastic = [d for f in ("tower_fa", "tower_ss", "tower_torsion") for d in fdofs.get(f, ())]
    for f in ("blade_flap", "blade_edge"):
        for dofs in fdofs.get(f, []):
            elastic += list(dofs)
    free_all = elastic + [d for d in RIGID_DOFS if d in free]
    system = System(bodies, free_all, fixed, prescribed, t.gravity if gravity else 0.0)
    return TurbineModel(system, t, modeset, fdofs, tips, shapes)
