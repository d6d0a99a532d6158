"""Symbolic equations of a scene (first paper sections 4.3-4.6): the scene
front of `multibody.symbolic`, restricted to the small models."""
from __future__ import annotations

from modesel.errors import ModeselError
from modesel.multibody.symbolic.model import MAX_DOFS, UNSUPPORTED_EFFECTS, SymbolicModel, derive
from modesel.simulation.assembly import build
from modesel.vocabulary import BLADE_FIELDS, TOWER_FIELDS


def check_supported(scene) -> None:
    """The small models of the first paper (sections 4.3-4.6): tower modes
    with rigid DOFs (shaft, platform, yaw, drivetrain) or blade modes on a
    rigid tower; no torsion, no aerodynamics, at most MAX_DOFS DOFs."""
    where = dict(file=scene.path)
    head = ("derive supports the small models only (first paper sections 4.3-4.6: tower modes with "
            f"shaft/platform DOFs, or blade modes on a rigid tower; at most {MAX_DOFS} DOFs)")
    for eff in UNSUPPORTED_EFFECTS:
        if scene.effects.get(eff):
            raise ModeselError(f"{head}: effect '{eff}' is not modelled symbolically", field=f"effects.{eff}",
                               **where)
    if "tower_torsion" in scene.fields:
        raise ModeselError(f"{head}: tower torsion is not supported", field="modes.tower_torsion", **where)
    tower = [f for f in scene.fields if f in TOWER_FIELDS]
    blade = [f for f in scene.fields if f in BLADE_FIELDS]
    if tower and blade:
        raise ModeselError(f"{head}: the scene has both tower and blade modes", field="modes", **where)
    n_blades = scene.turbine.num_blades
    n = (sum(scene.modes[f].count for f in tower) + n_blades * sum(scene.modes[f].count for f in blade)
         + len(scene.free))
    if n > MAX_DOFS:
        raise ModeselError(f"{head}: the scene has {n} DOFs", field="modes", **where)


def derive_scene(scene, modeset=None, **kw) -> SymbolicModel:
    """Check that `scene` is a supported small model, build its System with
    the numeric engine's template and derive it symbolically."""
    check_supported(scene)
    built = build(scene, modeset)
    system = built.model.system
    springs = None
    if "DrTr" in system.free:
        tb = built.model.turbine
        springs = {"DrTr": (tb.drivetrain_stiffness, tb.drivetrain_damping)}
    return derive(system, name=scene.name, springs=springs, description=getattr(scene, "description", "")
                  or "", **kw)
