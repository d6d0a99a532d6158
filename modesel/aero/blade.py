"""`AeroBlade`: the aerodynamic description of one blade (AeroDyn blade file).

Stations are the AeroDyn blade nodes (BlSpn): span measured along the blade
pitch axis from the blade root [m] (the root is at the hub radius from the
rotor apex). Chord [m], aerodynamic twist [rad] (positive towards feather,
angle of attack = inflow angle - pitch - twist) and the 0-based airfoil index
into `polars` are given at each station. The aerodynamic centre may lie off
the pitch axis (BlCrvAC out of plane, BlSwpAC in plane, in the blade frame
x towards the suction side/downwind, y towards the trailing edge: AeroDyn
places its nodes there, so they move and sit at a radius of their own), and
the blade reference line may carry a prebend angle (BlCrvAng, about the
blade y axis).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from modesel.errors import ModeselError
from modesel.aero.airfoils import PolarSet


@dataclass
class AeroBlade:
    """Aerodynamic properties of a blade at its AeroDyn nodes.

    span : (N,) BlSpn, distance from the blade root along the pitch axis [m].
    chord : (N,) BlChord [m].
    twist : (N,) BlTwist [rad].
    airfoil : (N,) 0-based airfoil index (BlAFID - 1) into `polars`.
    polars : the airfoil tables.
    source : file it was read from.
    crv_ac, swp_ac : (N,) BlCrvAC, BlSwpAC: offsets of the aerodynamic centre
        from the pitch axis along the blade x and y axes [m] (default 0).
    crv_angle : (N,) BlCrvAng [rad] (default 0).
    """

    span: np.ndarray
    chord: np.ndarray
    twist: np.ndarray
    airfoil: np.ndarray
    polars: PolarSet
    source: str | None = None
    notes: tuple = field(default_factory=tuple)
    crv_ac: np.ndarray | None = None
    swp_ac: np.ndarray | None = None
    crv_angle: np.ndarray | None = None

    def __post_init__(self):
        self.span = np.asarray(self.span, float)
        for name in ("crv_ac", "swp_ac", "crv_angle"):
            value = getattr(self, name)
            setattr(self, name, np.zeros(self.span.shape) if value is None else np.asarray(value, float))
        self.chord = np.asarray(self.chord, float)
        self.twist = np.asarray(self.twist, float)
        self.airfoil = np.asarray(self.airfoil, dtype=np.int64)
        n = self.span.size
        for name in ("chord", "twist", "airfoil", "crv_ac", "swp_ac", "crv_angle"):
            if getattr(self, name).shape != (n,):
                raise ModeselError(f"{name} has {getattr(self, name).size} values, "
                                   f"span has {n}", file=self.source, field=name)
        if n < 2 or np.any(np.diff(self.span) <= 0):
            raise ModeselError("blade stations must be strictly increasing (at least 2)",
                               file=self.source, field="BlSpn")
        if np.any(self.chord < 0):
            raise ModeselError("negative chord", file=self.source, field="BlChord")
        self.polars.offsets(self.airfoil)  # range check, raises ModeselError

    @property
    def length(self) -> float:
        """Aerodynamic blade length from root to last node [m]."""
        return float(self.span[-1] - self.span[0])

    def reference_line(self) -> np.ndarray:
        """(N, 3) node positions from the blade root in the blade frame [m]:
        (BlCrvAC, BlSwpAC, BlSpn), where AeroDyn places its nodes."""
        return np.stack([self.crv_ac, self.swp_ac, self.span], axis=1)

    def curve_length(self, hub_radius: float) -> np.ndarray:
        """(N,) AeroDyn's zLocal [m]: the hub radius plus the length of the
        polygon root -> node 1 -> ... -> node j through the node positions
        (`reference_line`); the tip- and hub-loss constants use it."""
        line = self.reference_line()
        steps = np.linalg.norm(np.diff(line, axis=0), axis=1)
        return hub_radius + np.linalg.norm(line[0]) + np.concatenate([[0.0], np.cumsum(steps)])

    def at(self, span):
        """(chord [m], twist [rad], airfoil index) at arbitrary span positions [m].

        Chord and twist are interpolated linearly (as AeroDyn maps node data);
        the airfoil is that of the nearest node (AeroDyn does not blend tables).
        Positions beyond the ends take the end values.
        """
        span = np.asarray(span, float)
        chord = np.interp(span, self.span, self.chord)
        twist = np.interp(span, self.span, self.twist)
        nearest = np.abs(span[..., None] - self.span).argmin(axis=-1)
        return chord, twist, self.airfoil[nearest]
