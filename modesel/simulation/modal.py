"""Modes of a scene: `linearize_scene` (natural frequencies, damping ratios,
labels; with a rotor speed, one point of a Campbell diagram)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from modesel.modeset import ModeSet
from modesel.multibody.linearize import linearize, modes
from modesel.simulation.assembly import build
from modesel.simulation.coleman import blade_groups, multiblade, with_whirl
from modesel.simulation.scene import Scene
from modesel.vocabulary import ROTOR_AZIMUTH


def linearize_scene(scene: Scene, modeset: ModeSet | None = None, rpm: float | None = None):
    """Modes of the scene linearised at its initial state with zero elastic
    deflection; with `rpm` the rotor turns at that constant speed.

    A three-bladed rotor on a flexible support (tower, yaw or platform DOFs)
    is analysed in multi-blade coordinates (simulation/coleman.py): each
    blade DOF type X (F1, E1, ...) becomes X_coll, X_cos, X_sin, and modes
    are labelled by participation over these coordinates, frequencies being
    those seen in the fixed frame (Campbell diagram); a turning rotor's
    cyclic modes are marked forward or backward whirl. For a parked rotor
    with blade 1 up, X_cos is the rotor "pitch" (tilt) asymmetric mode of
    flap and the "yaw" one of edge, X_sin the flap "yaw" and edge "pitch"
    modes (Jonkman 2009 Table 9-1 naming). Otherwise (rotor on a rigid
    support) the blades are analysed in the rotating frame and labelled by
    their own DOF (B1F1 ...). Labels: `multibody.linearize` module doc.
    The equations are the compiled right-hand side's (`Built.rhs`, its
    `linear_model`), whose gearbox losses hold the factor of the initial
    state, as ElastoDyn's linearisation holds the previous step's sign
    (`multibody.gearbox`). Returns (modes, LinearModel)."""
    if rpm is not None:
        scene = replace(scene, constant_speed={ROTOR_AZIMUTH: rpm * np.pi / 30.0},
                        free=tuple(d for d in scene.free if d != ROTOR_AZIMUTH))
    built = build(scene, modeset)
    names = list(built.model.system.free)
    qd0 = rotor_rates(built)
    groups = blade_groups(names, built.model.turbine.num_blades)
    if groups is None:
        lin = linearize(built.rhs(), np.zeros_like(built.q0), qd0, names)
        return modes(lin), lin
    omega = rotor_speed(built, qd0)
    lin = multiblade(built, groups, qd0, omega)
    return with_whirl(modes(lin), lin.names, omega), lin


def rotor_rates(built) -> np.ndarray:
    """Rates of the free coordinates for linearising: the rotor azimuth's
    initial speed [rad/s], zero for the others."""
    out = np.zeros(len(built.q0))
    for i, n in enumerate(built.model.system.free):
        if n == ROTOR_AZIMUTH:
            out[i] = built.qd0[i]
    return out


def rotor_speed(built, qd0) -> float:
    """Rotor speed [rad/s]: prescribed, or the free azimuth's rate in qd0, else 0."""
    sys = built.model.system
    if ROTOR_AZIMUTH in sys.prescribed:
        return float(sys.prescribed[ROTOR_AZIMUTH].rate)
    if ROTOR_AZIMUTH in sys.free:
        return float(qd0[sys.free.index(ROTOR_AZIMUTH)])
    return 0.0
