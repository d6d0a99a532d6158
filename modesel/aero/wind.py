"""Wind field: uniform (optionally time-varying) wind with power-law shear.

    u(z, t) = U(t) (z / z_ref)^alpha     for z > 0,   u = 0 for z <= 0

U(t) is the speed at the reference height: constant `speed`, or linear
interpolation in a (time, speed) series, held constant beyond its ends.
The wind blows horizontally along `direction` [rad], measured from the
ElastoDyn x axis (downwind) towards y; direction 0 is aligned with the
un-yawed rotor. `alpha = 0` gives a uniform field; the IEC 61400-1 normal
wind profile uses alpha = 0.2. The default reference height 90 m is the
NREL 5-MW hub height.

The profile is one formula with two implementations: `power_law` (numpy,
any shapes) and its compiled scalar twin `power_law_at` (numba, called from
the compiled inflow and tower-drag loops); tests/test_twins.py holds them
equal.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from modesel.errors import ModeselError


def power_law(z, speed, shear_exponent: float, reference_height: float):
    """Power-law wind profile u = U (z / z_ref)^alpha for z > 0, 0 for z <= 0.

    z : heights above ground [m] (any shape, broadcast with `speed`).
    speed : U, the speed at the reference height [m/s].
    shear_exponent : alpha [-]; reference_height : z_ref [m] (> 0).
    Returns u [m/s].
    """
    z = np.asarray(z, float)
    ratio = np.where(z > 0, z, 1.0) / reference_height
    return speed * np.where(z > 0, ratio ** shear_exponent, 0.0)


@njit(cache=True)
def power_law_at(z, speed, shear_exponent, reference_height):
    """`power_law` at one height z [m] (compiled scalar twin) [m/s]."""
    if z > 0.0:
        return speed * (z / reference_height) ** shear_exponent
    return 0.0


class Wind:
    """Steady or time-varying uniform wind with power-law shear.

    speed : reference-height speed [m/s] (used when no `time_series`).
    shear_exponent : power-law exponent alpha [-].
    reference_height : z_ref [m] above ground.
    time_series : (times [s], speeds [m/s]) pair of arrays, or an (N, 2) array.
    direction : horizontal direction the wind blows to, from x towards y [rad].
    """

    def __init__(self, speed: float = 0.0, shear_exponent: float = 0.0,
                 reference_height: float = 90.0, time_series=None, direction: float = 0.0):
        if reference_height <= 0:
            raise ModeselError(f"reference height must be > 0, got {reference_height}",
                               field="reference_height")
        if not np.isfinite(shear_exponent):
            raise ModeselError("shear exponent must be finite", field="shear_exponent")
        self.speed = float(speed)
        self.shear_exponent = float(shear_exponent)
        self.reference_height = float(reference_height)
        self.direction = float(direction)
        self.times = self.speeds = None
        if time_series is not None:
            series = np.asarray(time_series, float)
            if series.ndim == 2 and series.shape[1] == 2 and series.shape[0] != 2:
                series = series.T
            if series.ndim != 2 or series.shape[0] != 2 or series.shape[1] < 1:
                raise ModeselError("time series must be (times, speeds)", field="time_series")
            times, speeds = series
            if not (np.all(np.isfinite(times)) and np.all(np.isfinite(speeds))):
                raise ModeselError("time series has non-finite values", field="time_series")
            if np.any(np.diff(times) <= 0):
                raise ModeselError("time series times must be strictly increasing",
                                   field="time_series")
            self.times, self.speeds = times, speeds

    def reference_speed(self, t=0.0):
        """U(t) at the reference height [m/s]."""
        if self.times is None:
            return np.full(np.shape(t), self.speed) if np.ndim(t) else self.speed
        return np.interp(t, self.times, self.speeds)

    def velocity(self, z, t=0.0):
        """Horizontal wind speed u(z, t) [m/s] (broadcast over z [m] and t [s])."""
        return power_law(z, self.reference_speed(t), self.shear_exponent, self.reference_height)

    def vector(self, z, t=0.0):
        """Wind velocity vectors (..., 3) [m/s] in the ElastoDyn axes."""
        u = np.asarray(self.velocity(z, t))
        return np.stack([u * np.cos(self.direction), u * np.sin(self.direction),
                         np.zeros_like(u)], axis=-1)
