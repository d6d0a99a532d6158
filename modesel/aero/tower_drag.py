"""Quasi-steady tower drag per unit length (second paper, eq. 51).

    p = 1/2 rho Cd(z) d(z) |v_rel| v_rel,      v_rel = v_wind - v_tower

Eq. 51 prints the magnitude |v_w|^2; the vector form |v_rel| v_rel used here
has that magnitude and keeps the direction (and sign) of the relative flow,
so a tower moving downwind faster than the wind is pushed back. Only the
components normal to the (undeflected, vertical) tower axis load the tower:
for 3-component velocities the vertical component is discarded.

Diameter and drag coefficient come from the AeroDyn table (TwrElev [m above
ground / MSL], TwrDiam [m], TwrCd [-]), linearly interpolated and held
constant beyond the table ends (the `tower_drag` effect loads only the span
the table covers, as OpenFAST). Without a table, `TowerDrag.nrel5mw_default`
gives the NREL 5-MW values (diameter 6 m at the base to 3.87 m at the top,
Cd = 1.0; Jonkman et al. 2009, NREL/TP-500-38060).

`TowerDrag.load` (numpy, any shapes) has a compiled twin, `drag_forces`
(numba, node loop with the wind of `aero.wind.wind_velocity`), for the
`tower_drag` effect; tests/test_twins.py holds them equal.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from modesel.aero.wind import wind_at
from modesel.errors import ModeselError


@dataclass
class TowerDrag:
    """Tower diameter / drag-coefficient table and the eq. 51 load."""

    elevation: np.ndarray
    diameter: np.ndarray
    drag_coefficient: np.ndarray
    source: str | None = None
    turbulence: np.ndarray | None = None      # TwrTI [-] (Eames' tower shadow), None where the table has none

    def __post_init__(self):
        if self.turbulence is not None:
            self.turbulence = np.asarray(self.turbulence, float)
        self.elevation = np.asarray(self.elevation, float)
        self.diameter = np.asarray(self.diameter, float)
        self.drag_coefficient = np.asarray(self.drag_coefficient, float)
        n = self.elevation.size
        if n < 1 or self.diameter.shape != (n,) or self.drag_coefficient.shape != (n,):
            raise ModeselError("TwrElev, TwrDiam and TwrCd need the same number of rows (>= 1)",
                               file=self.source, field="TwrElev")
        if np.any(np.diff(self.elevation) <= 0):
            raise ModeselError("tower elevations must be strictly increasing",
                               file=self.source, field="TwrElev")
        if np.any(self.diameter < 0) or np.any(self.drag_coefficient < 0):
            raise ModeselError("tower diameter and drag coefficient must be >= 0",
                               file=self.source, field="TwrDiam")

    @classmethod
    def nrel5mw_default(cls, tower_height: float = 87.6, base_height: float = 0.0):
        """NREL 5-MW tower: 6 m at the base, 3.87 m at the top, Cd = 1.0."""
        return cls(elevation=np.array([base_height, tower_height]),
                   diameter=np.array([6.0, 3.87]), drag_coefficient=np.array([1.0, 1.0]),
                   source="NREL 5-MW default (NREL/TP-500-38060)")

    def properties(self, z):
        """(diameter [m], Cd [-]) at elevations `z` [m]."""
        z = np.asarray(z, float)
        return (np.interp(z, self.elevation, self.diameter),
                np.interp(z, self.elevation, self.drag_coefficient))

    def coefficient(self, z, air_density: float = 1.225):
        """1/2 rho Cd(z) d(z) [kg/m^2] at elevations `z` [m]: the load per unit
        length is this times |v_rel| v_rel (eq. 51)."""
        d, cd = self.properties(z)
        return 0.5 * air_density * cd * d

    def load(self, z, wind_velocity, tower_velocity=0.0, air_density: float = 1.225):
        """Drag force per unit tower length [N/m], eq. 51.

        z : (...) elevations [m].
        wind_velocity, tower_velocity : (...) speeds along x [m/s], or (..., 2)
            / (..., 3) vectors (shape z.shape + (k,)) in the ElastoDyn axes
            (x downwind, y left, z up); the z component is ignored.
        Returns an array of the same shape as the (broadcast) velocities,
        with a zero z component for 3-vectors.
        """
        v_rel = np.asarray(wind_velocity, float) - np.asarray(tower_velocity, float)
        c = self.coefficient(z, air_density)
        if v_rel.ndim == np.ndim(z) + 1 and v_rel.shape[-1] in (2, 3):
            normal = v_rel.copy()
            if normal.shape[-1] == 3:
                normal[..., 2] = 0.0
            speed = np.sqrt(np.sum(normal * normal, axis=-1))
            return (c * speed)[..., None] * normal
        return c * np.abs(v_rel) * v_rel


@njit(cache=True)
def drag_forces(pos, vel, wp, coef, out, field=None):
    """Compiled twin of `TowerDrag.load` for 3-vectors at points k (eq. 51):
    out_k = coef_k |v_rel| v_rel, v_rel the horizontal wind at the point
    (`aero.wind.wind_velocity`, parameters wp = `Wind.params(t)`) minus the
    point's horizontal velocity vel[k] [m/s]; out[k, 2] = 0 (AeroDyn's TwrAero
    load, ADTwr_CalcOutput: the components normal to the tower). With
    coef_k = `TowerDrag.coefficient` times a length [m] the result is a force
    [N] (per unit length [N/m] without). field None: uniform wind only
    (`aero.wind.wind_at`)."""
    for k in range(pos.shape[0]):
        u0, u1, _ = wind_at(wp, pos[k, 0], pos[k, 1], pos[k, 2], field)
        v0 = u0 - vel[k, 0]
        v1 = u1 - vel[k, 1]
        s = coef[k] * np.sqrt(v0 * v0 + v1 * v1)
        out[k, 0] = s * v0
        out[k, 1] = s * v1
        out[k, 2] = 0.0
