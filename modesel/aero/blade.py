"""`AeroBlade`: the aerodynamic description of one blade (AeroDyn blade file).

Stations are the AeroDyn blade nodes (BlSpn): span measured along the blade
pitch axis from the blade root [m] (the root is at the hub radius from the
rotor apex). Chord [m], aerodynamic twist [rad] (positive towards feather,
angle of attack = inflow angle - pitch - twist) and the 0-based airfoil index
into `polars` are given at each station.
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
    """

    span: np.ndarray
    chord: np.ndarray
    twist: np.ndarray
    airfoil: np.ndarray
    polars: PolarSet
    source: str | None = None
    notes: tuple = field(default_factory=tuple)

    def __post_init__(self):
        self.span = np.asarray(self.span, float)
        self.chord = np.asarray(self.chord, float)
        self.twist = np.asarray(self.twist, float)
        self.airfoil = np.asarray(self.airfoil, dtype=np.int64)
        n = self.span.size
        for name in ("chord", "twist", "airfoil"):
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
