"""Coordinate vocabulary: the one home of the names of flexible fields and
degrees of freedom (DOFs), what they mean, their directions and units.

Fields (flexible directions of the tower and the blades):
`tower_fa`, `tower_ss`, `tower_torsion`, `blade_flap`, `blade_edge`.

DOF names are ElastoDyn's (OpenFAST writes a coordinate as channel Q_<name>):

- elastic, mode i = 1, 2, ...: tower TFA<i>, TSS<i>, TTor<i>; blade b = 1, 2, ...
  B<b>F<i> (flap), B<b>E<i> (edge);
- multi-blade (Coleman) coordinates of the blade DOF type F<i> / E<i>
  (Bir 2008, NREL/CP-500-42553): F<i>_coll, F<i>_cos, F<i>_sin;
- drivetrain (elastic shafts, second paper eq. 17-20): DrTr (low-speed shaft
  twist), HSSTw (high-speed shaft twist referred to the LSS);
- rigid body (no restoring stiffness of their own): GeAz (generator azimuth,
  LSS side), Yaw, PtfmSurge, PtfmPitch;
- reaction (always fixed at 0, model/template.py): rotations TwrBsR<a>t,
  YawBrR<a>p, RootR<a>c<b> and translations TwrBsT<a>t, YawBrT<a>p,
  RootT<a>c<b> (a = x, y, z) at the tower base, the yaw bearing and blade
  b's root, and LSShftTxa along the shaft.

Units of a coordinate: m for bending modes (tip-normalised shapes) and
PtfmSurge, rad for the others; its rate per s.
"""
from __future__ import annotations

import re
from typing import NamedTuple

import numpy as np

FIELDS = ("tower_fa", "tower_ss", "tower_torsion", "blade_flap", "blade_edge")
TOWER_FIELDS = ("tower_fa", "tower_ss", "tower_torsion")
BLADE_FIELDS = ("blade_flap", "blade_edge")
#: DOF-name stem of each field's modes: TFA1, B1F1, ...
FIELD_PREFIX = {"tower_fa": "TFA", "tower_ss": "TSS", "tower_torsion": "TTor", "blade_flap": "F",
                "blade_edge": "E"}

#: direction keyword of each field (shape_integrals' `direction` argument)
FIELD_DIRECTIONS = {"tower_fa": "fa", "tower_ss": "ss", "blade_flap": "flap", "blade_edge": "edge",
                    "tower_torsion": "torsion"}
#: displacement direction of each bending keyword in the beam's body frame
#: (ElastoDyn: Q_TSS displaces the tower top along -y)
DIRECTIONS = {"fa": (1.0, 0.0, 0.0), "flap": (1.0, 0.0, 0.0), "ss": (0.0, -1.0, 0.0), "edge": (0.0, 1.0, 0.0)}
#: displacement direction of each bending field in its body frame
FIELD_DIRECTION = {f: np.array(DIRECTIONS[d]) for f, d in FIELD_DIRECTIONS.items() if d in DIRECTIONS}

RIGID_BODY_DOFS = ("GeAz", "Yaw", "PtfmSurge", "PtfmPitch")
DRIVETRAIN_DOFS = ("DrTr", "HSSTw")
#: the coordinates that are not modes of a field, in the order of the model's free list
RIGID_DOFS = ("GeAz", "DrTr", "HSSTw", "Yaw", "PtfmSurge", "PtfmPitch")
#: those a scene frees or fixes itself (HSSTw comes with the two-spring drivetrain effect)
SCENE_DOFS = ("GeAz", "DrTr", "Yaw", "PtfmSurge", "PtfmPitch")
#: the rotor azimuth, the only coordinate a scene can turn at a constant speed
ROTOR_AZIMUTH = "GeAz"
#: reaction coordinates (fixed at 0) whose generalised forces are the loads
#: TwrBsMyt, TwrBsMxt (tower base) and RotThrust (low-speed shaft thrust)
TOWER_BASE_REACTION = "TwrBsRyt"
TOWER_BASE_REACTION_X = "TwrBsRxt"
SHAFT_THRUST_REACTION = "LSShftTxa"
#: ElastoDyn's tower-base and yaw-bearing loads (kN, kN m), each the
#: generalised force of a reaction coordinate: a translation (T) along or a
#: rotation (R) about an axis of the tower-base frame t (ground) or of the
#: tower-top frame p (turned by the tower's deflection, not by the yaw)
TOWER_LOAD_REACTIONS = {
    "TwrBsFxt": "TwrBsTxt", "TwrBsFyt": "TwrBsTyt", "TwrBsFzt": "TwrBsTzt",
    "TwrBsMxt": TOWER_BASE_REACTION_X, "TwrBsMyt": TOWER_BASE_REACTION, "TwrBsMzt": "TwrBsRzt",
    "YawBrFxp": "YawBrTxp", "YawBrFyp": "YawBrTyp", "YawBrFzp": "YawBrTzp",
    "YawBrMxp": "YawBrRxp", "YawBrMyp": "YawBrRyp", "YawBrMzp": "YawBrRzp"}
#: ElastoDyn's low-speed shaft loads at the shaft tip (the rotor apex; kN, kN m), in
#: the nonrotating shaft frame s (y_s to the left, z_s up, both normal to the shaft):
#: each the generalised force of a reaction coordinate of the hub's joint, a
#: translation (T) along or a rotation (R) about y_s or z_s
SHAFT_LOAD_REACTIONS = {"LSShftFys": "LSShftTys", "LSShftFzs": "LSShftTzs",
                        "LSSTipMys": "LSSTipRys", "LSSTipMzs": "LSSTipRzs"}
REACTIONS = (TOWER_BASE_REACTION, TOWER_BASE_REACTION_X, SHAFT_THRUST_REACTION) + tuple(
    c for c in TOWER_LOAD_REACTIONS.values() if c not in (TOWER_BASE_REACTION, TOWER_BASE_REACTION_X)) + tuple(
    SHAFT_LOAD_REACTIONS.values())
MULTIBLADE_PARTS = ("coll", "cos", "sin")
#: rigid coordinates measured in m (the others in rad)
TRANSLATIONS = ("PtfmSurge",)


class Dof(NamedTuple):
    """What a DOF name means: kind ('elastic', 'drivetrain', 'rigid',
    'reaction'), blade number (None off the blades and for multi-blade
    coordinates), field (elastic only), mode number (elastic only) and the
    multi-blade part ('coll', 'cos', 'sin'; None in the blades' own frame)."""

    kind: str
    blade: int | None = None
    field: str | None = None
    index: int | None = None
    multiblade: str | None = None


_TOWER = re.compile(r"(TFA|TSS|TTor)([1-9]\d*)")
_BLADE = re.compile(r"B([1-9]\d*)([FE])([1-9]\d*)")
_MULTIBLADE = re.compile(r"([FE])([1-9]\d*)_(coll|cos|sin)")
_ROOT_REACTION = re.compile(r"Root[RT][xyz]c([1-9]\d*)")
_FIELD_OF_PREFIX = {p: f for f, p in FIELD_PREFIX.items()}


def parse_dof(name: str) -> Dof:
    """The meaning of DOF `name` (module doc); ValueError if it is none."""
    if m := _TOWER.fullmatch(name):
        return Dof("elastic", None, _FIELD_OF_PREFIX[m.group(1)], int(m.group(2)))
    if m := _BLADE.fullmatch(name):
        return Dof("elastic", int(m.group(1)), _FIELD_OF_PREFIX[m.group(2)], int(m.group(3)))
    if m := _MULTIBLADE.fullmatch(name):
        return Dof("elastic", None, _FIELD_OF_PREFIX[m.group(1)], int(m.group(2)), m.group(3))
    if name in DRIVETRAIN_DOFS:
        return Dof("drivetrain")
    if name in RIGID_BODY_DOFS:
        return Dof("rigid")
    if name in REACTIONS:
        return Dof("reaction")
    if m := _ROOT_REACTION.fullmatch(name):
        return Dof("reaction", int(m.group(1)))
    raise ValueError(f"not a DOF name: {name!r}")


def dof_name(field: str, index: int, blade: int | None = None) -> str:
    """Name of mode `index` (from 1) of `field`, on blade `blade` for a blade field."""
    if (blade is None) != (field in TOWER_FIELDS):
        raise ValueError(f"{field} {'needs' if blade is None else 'takes no'} blade number")
    stem = FIELD_PREFIX[field]
    return f"{stem}{index}" if blade is None else f"B{blade}{stem}{index}"


def field_dofs(field: str, count: int, blade: int | None = None) -> tuple:
    """Names of the first `count` modes of `field` (on blade `blade`)."""
    return tuple(dof_name(field, i + 1, blade) for i in range(count))


def blade_dof_type(name: str) -> str:
    """The blade DOF type of a blade or multi-blade coordinate ('B2F1',
    'F1_cos' -> 'F1'): the same mode of every blade."""
    d = parse_dof(name)
    if d.kind != "elastic" or d.field not in BLADE_FIELDS:
        raise ValueError(f"not a blade coordinate: {name!r}")
    return f"{FIELD_PREFIX[d.field]}{d.index}"


def multiblade_name(dof_type: str, part: str) -> str:
    """Multi-blade coordinate `part` ('coll', 'cos', 'sin') of a blade DOF type ('F1')."""
    if part not in MULTIBLADE_PARTS:
        raise ValueError(f"multi-blade part must be one of {MULTIBLADE_PARTS}, got {part!r}")
    return f"{dof_type}_{part}"


def root_reaction(blade: int, axis: str = "y", kind: str = "R") -> str:
    """Name of blade `blade`'s root reaction coordinate: a rotation (kind
    "R", the moment RootM<axis>c<b>) about or a translation (kind "T", the
    force RootF<axis>c<b>) along the coned `axis` (x, y or z)."""
    if axis not in ("x", "y", "z") or kind not in ("R", "T"):
        raise ValueError(f"root reaction axis must be x, y or z and kind R or T, got {axis!r}, {kind!r}")
    return f"Root{kind}{axis}c{blade}"


def is_blade_body(body: str) -> bool:
    """Whether a body of the turbine template ('blade1', 'tower', 'hub', ...) is a blade."""
    return re.fullmatch(r"blade[1-9]\d*", body) is not None


def is_blade_field(field: str) -> bool:
    return field in BLADE_FIELDS


def is_translation(name: str) -> bool:
    """The coordinate is a displacement [m] (bending modes, PtfmSurge), not an angle [rad]."""
    d = parse_dof(name)
    if d.kind == "elastic":
        return d.field != "tower_torsion"
    return name in TRANSLATIONS


def dof_unit(name: str, rate: bool = False) -> str:
    """Unit of coordinate `name` ('m' or 'rad'), or of its rate ('m/s', 'rad/s')."""
    unit = "m" if is_translation(name) else "rad"
    return unit + "/s" if rate else unit


def coordinate_field(name: str) -> str | None:
    """What an elastic coordinate is, for messages: its field, or
    'drivetrain' for DrTr/HSSTw; None for the others."""
    d = parse_dof(name)
    return d.field if d.kind == "elastic" else "drivetrain" if d.kind == "drivetrain" else None
