"""Distributed properties of a slender beam (tower or blade).

All arrays are sampled at the same stations `span` (m from the beam root
along its axis). Adjustment factors of the deck are already applied.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class BeamProperties:
    """Distributed properties of a tower or blade.

    Attributes
    ----------
    name : "tower" or "blade".
    span : (N,) station positions from the root along the axis [m], span[0] = 0,
        span[-1] = flexible length.
    mass : (N,) mass per unit length [kg/m].
    ei_1 : (N,) bending stiffness for displacement along the body x axis:
        tower fore-aft, blade flap [N m^2].
    ei_2 : (N,) bending stiffness for displacement along the body y axis:
        tower side-side, blade edge [N m^2].
    gj : (N,) torsional stiffness [N m^2].
    polar_inertia : (N,) mass moment of inertia per unit length about the axis [kg m].
    twist : (N,) structural twist [rad] (zeros for the tower).
    root_offset : distance from the body origin to the beam root along the
        axis [m] (tower: 0 with the origin at the tower base; blade: hub radius).
    damping_ratio : {field: [zeta_1, zeta_2, ...]} modal damping ratios as
        fractions of critical (ElastoDyn gives percent; converted here).
    notes : documented defaults that were applied (e.g. torsion properties
        missing from the deck), one sentence each.
    stiffness_tuners : {field: [t_1, t_2, ...]} ElastoDyn modal stiffness
        tuners (FAStTunr, SSStTunr, FlStTunr): ElastoDyn multiplies the
        generalised stiffness K_il of the modes in its file by
        sqrt(t_i t_l). modesel applies them to the field's shapes of any
        family (mode k > len(tuners) takes the last one), as OpenFAST does
        to the fits `modesel export` writes (the export warns when one is
        not 1). Empty when not given.
    source : file the properties were read from, if any.
    """

    name: str
    span: np.ndarray
    mass: np.ndarray
    ei_1: np.ndarray
    ei_2: np.ndarray
    gj: np.ndarray
    polar_inertia: np.ndarray
    twist: np.ndarray
    root_offset: float = 0.0
    damping_ratio: dict = field(default_factory=dict)
    notes: tuple = ()
    stiffness_tuners: dict = field(default_factory=dict)
    source: str | None = None

    @property
    def length(self) -> float:
        """Flexible length [m]."""
        return float(self.span[-1] - self.span[0])

    @property
    def total_mass(self) -> float:
        """Mass of the beam [kg] (trapezoidal rule on the stations)."""
        return float(np.trapezoid(self.mass, self.span))

    def stiffness(self, direction: str) -> np.ndarray:
        """EI for 'fa'/'flap' (ei_1), 'ss'/'edge' (ei_2), or GJ for 'torsion'."""
        if direction in ("fa", "flap"):
            return self.ei_1
        if direction in ("ss", "edge"):
            return self.ei_2
        if direction == "torsion":
            return self.gj
        raise ValueError(direction)
