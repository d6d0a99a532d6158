"""Effects a scene switches on in its [effects] table, one module each,
behind the `Effect` interface (`base.py`), selected by `select(scene)`.

    wind        steady or time-varying uniform wind with power-law shear (input of aero, tower_drag)
    pitch       prescribed constant collective pitch
    drivetrain  ElastoDyn torsional spring/damper on DrTr, or the second paper's LSS/HSS springs
    yaw         ServoDyn's yaw spring/damper about the neutral yaw on a free Yaw
    generator   generator torque: constant, locked, or the NREL 5-MW variable-speed law
    damping     structural damping: the deck's modal ratios, or second paper eq. 46-50
    aero        BEM blade loads with structural motion and Pitt-Peters skew (second paper section 3)
    tower_drag  quasi-steady tower drag (second paper eq. 51)

`gravity`, `geometric_stiffening`, `structural_twist` (blade shapes that
turn with the structural twist, model/template.py) and `elastodyn_nodes` (beams
integrated on the deck's ElastoDyn analysis nodes, model/template.py) are flags of
the system itself (the engine's kinematics), not modules; the first three
default to true, `elastodyn_nodes` to false except in a scene read from an
ElastoDyn or .fst file. An effect that is off is not imported,
not constructed and never evaluated.
"""
from __future__ import annotations

import importlib

#: [effects] key -> module, in the order effects are configured and evaluated
MODULES = {
    "wind": "wind",
    "pitch": "pitch",
    "drivetrain": "drivetrain",
    "yaw": "yaw",
    "generator": "generator",
    "damping": "damping",
    "aero": "aero",
    "tower_drag": "tower_drag",
}
FLAGS = ("gravity", "geometric_stiffening", "structural_twist", "elastodyn_nodes")
#: effects that may be on without being named in the scene (damping always,
#: drivetrain when DrTr is free; see their `default_on_for`)
DEFAULT_ON = ("damping", "drivetrain")
KEYS = FLAGS + tuple(MODULES)


def effect_class(name: str):
    """The Effect subclass of [effects] key `name` (imports its module)."""
    module = importlib.import_module(f"{__name__}.{MODULES[name]}")
    return module.EFFECT


def validate(effects: dict, file=None, base_dir=None) -> None:
    """Check the options of every effect mentioned in a scene's [effects]."""
    from modesel.errors import ModeselError
    for name, value in effects.items():
        if name in FLAGS:
            if not isinstance(value, bool):
                raise ModeselError(f"must be true or false, got {value!r}", file=file, field=f"effects.{name}")
            continue
        if value is False:
            continue
        effect_class(name).parse_options(value, file, base_dir)


def select(scene) -> list:
    """The switched-on effects of `scene`, constructed, in `MODULES` order."""
    from pathlib import Path
    base_dir = None if scene.path is None else Path(scene.path).parent
    out = []
    for name in MODULES:
        value = scene.effects.get(name)
        if value is False:
            continue
        if value is None and name not in DEFAULT_ON:
            continue
        cls = effect_class(name)
        if not cls.applies(scene):
            continue
        out.append(cls(scene, cls.parse_options(value, scene.path, base_dir)))
    return out


def effects_in_scene(scene, dof_names) -> tuple[list, list, list]:
    """(effects evaluated, system flags on, warnings about settings that act
    on nothing) of `scene` with free coordinates `dof_names`; the same
    selection as `select`; `modesel simulate` and the report print it."""
    on = []
    for name in MODULES:
        value = scene.effects.get(name)
        if value is False or (value is None and name not in DEFAULT_ON):
            continue
        if effect_class(name).applies(scene):
            on.append(name)
    flags = [f for f in FLAGS if scene.effects.get(f, f != "elastodyn_nodes")]
    warnings = []
    if "wind" in on and not {"aero", "tower_drag"} & set(on):
        warnings.append("[effects.wind] is set but neither aero nor tower_drag is on: the wind loads nothing")
    for name in ("aero", "tower_drag"):
        if name in on and "wind" not in on:
            warnings.append(f"{name} is on without [effects.wind]: it acts in still air")
    # an OpenFAST case with GenDOF off keeps ServoDyn's generator for GenTq and GenPwr, which OpenFAST
    # writes (the law at the fixed speed): not a setting that acts on nothing (`simulation.fst`)
    from_fst = scene.path is not None and str(scene.path).lower().endswith(".fst")
    if "generator" in on and "GeAz" not in dof_names and not from_fst:
        warnings.append("generator torque is on but GeAz is not free: it acts on nothing")
    if "drivetrain" in on and "DrTr" not in dof_names and "drivetrain" in scene.effects:
        warnings.append("[effects.drivetrain] is set but DrTr is not free: it acts on nothing")
    for name, value in scene.effects.items():
        if name in MODULES and value not in (None, False) and name not in on:
            warnings.append(f"[effects] {name} is set but does not apply to this scene")
    return on, flags, warnings
