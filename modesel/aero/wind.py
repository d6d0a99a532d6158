"""Wind field: InflowWind's uniform wind (OpenFAST `IfW_FlowField.f90`,
`UniformField_GetVel`), steady or tabulated in time.

At a point (x, y, z) [m] (ElastoDyn inertial axes: x downwind, y to the
left looking downwind, z up from the ground) and time t, with the
parameters interpolated linearly in time (held beyond the table's ends):

    V1 = VelH ((z/RefHt)^ShrV + (ShrH (y cos AngleH + x sin AngleH)
                                 + LinShrV (z - RefHt)) / RefLength) + VelGust
    V1' = cos(AngleV) V1 - sin(AngleV) VelV          (upflow AngleV)
    w   = sin(AngleV) V1 + cos(AngleV) VelV
    velocity = (V1' cos AngleH, -V1' sin AngleH, w)

(the columns of an InflowWind uniform wind file, WindType 2: time, VelH
horizontal speed, AngleH direction [positive rotates the flow towards -y],
VelV vertical speed, ShrH linear horizontal shear, ShrV power-law exponent,
LinShrV linear vertical shear, VelGust gust speed, optional AngleV upflow).
Steady wind (WindType 1) is the single row (0, HWindSpeed, 0, 0, 0, PLExp,
0, 0, 0) with RefLength 1. At or below the ground the velocity is zero, as
InflowWind's (`UniformField_GetVel` is called for z > 0 only): z <= GROUND,
1 nm, so that a point placed on the ground (AeroDyn's tower station at
TwrElev 0), which the kinematics put at 2e-15 m, is on it.

InflowWind's upflow VFlowAng theta (`upflow`, with PropagationDir 0) tilts
the whole field about the hub point r = (0, 0, RefHt) (InflowWind_Subs.f90
InflowWind_SetParameters, IfW_FlowField.f90 FlowField_GetVelAcc): a point
is taken into the wind frame, p' = R^T (p - r) + r with R the rotation by
theta about y, so x' = cos(theta) x + sin(theta) (z - RefHt) and z' = RefHt
- sin(theta) x + cos(theta) (z - RefHt), the velocity v' above is evaluated
there (zero where z' <= GROUND) and turned back, v = R v' =
(cos(theta) u' - sin(theta) w', v', sin(theta) u' + cos(theta) w').

A full field (InflowWind WindType 3, a TurbSim file: `aero.full_field`)
replaces the table: `params(t)` is then the field packed after the
uniform parameters, with its time slot set to t, and `wind_velocity` reads
it (`GRID_SLOT` holds where it starts; 0 for uniform wind). InflowWind's
PropagationDir turns a full field about the vertical through the hub
point: with d = `direction` (= -PropagationDir, from x towards y) a point
is read at p' = R_z(-d) p, x' = cos(d) x + sin(d) y, y' = -sin(d) x +
cos(d) y (its frozen-turbulence time from x'), and the velocity turned back,
v = R_z(d) v'. params[12:14] hold the cosine and sine of the field's turn:
the upflow for a uniform wind, the direction for a full field.

The short form of a scene's [effects.wind] (`speed`, `shear`,
`direction` from x towards +y, `time_series` of (t, speed)) is the table
with AngleH = -direction. alpha = 0.2 gives the IEC 61400-1 normal wind
profile; the default reference height 90 m is the NREL 5-MW hub height.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from modesel.aero.full_field import grid_velocity
from modesel.errors import ModeselError

#: height [m] at or below which a point is on the ground (module doc)
GROUND = 1e-9

#: uniform wind table columns (InflowWind's order; angles in rad here)
COLUMNS = ("Time", "VelH", "AngleH", "VelV", "ShrH", "ShrV", "LinShrV", "VelGust", "AngleV")
#: layout of `Wind.params(t)`: the table's row (10: VelH, cos and sin AngleH, VelV, ShrH,
#: ShrV, LinShrV, VelGust, cos and sin AngleV), RefHt, RefLength, cos and sin of the field's
#: turn (the upflow; for a full field its direction: module doc)
N_PARAMS = 14
#: params[GRID_SLOT] > 0: a full field packed from that index (module doc); the
#: slot between (N_PARAMS) is the compiled loads' channel flag (`effects.packing`)
GRID_SLOT = N_PARAMS + 1


class Wind:
    """Uniform wind (module doc).

    speed : reference-height speed [m/s] (used when no table or series).
    shear_exponent : power-law exponent alpha [-].
    reference_height : RefHt [m] above ground.
    time_series : (times [s], speeds [m/s]) pair of arrays, or an (N, 2) array.
    direction : horizontal direction the wind blows to, from x towards y [rad].
    table : (N, 8 or 9) uniform-wind table in `COLUMNS` order (angles in rad);
        replaces speed, shear, time_series and direction.
    reference_length : RefLength [m] of the linear shears.
    full_field : an `aero.full_field.FullField` (TurbSim); replaces the
        uniform wind (speed etc. then describe its hub-height mean).
    upflow : InflowWind's VFlowAng [rad], the field tilted about the hub
        point (module doc; uniform wind only).
    """

    def __init__(self, speed: float = 0.0, shear_exponent: float = 0.0,
                 reference_height: float = 90.0, time_series=None, direction: float = 0.0,
                 table=None, reference_length: float = 1.0, full_field=None, upflow: float = 0.0):
        self.full_field = full_field
        if not np.isfinite(upflow) or (upflow != 0.0 and full_field is not None):
            raise ModeselError("the upflow angle must be finite, and tilts a uniform wind only", field="upflow")
        self.upflow = float(upflow)
        if full_field is not None:
            speed, table, time_series = full_field.mean_speed, None, None
        if reference_height <= 0:
            raise ModeselError(f"reference height must be > 0, got {reference_height}",
                               field="reference_height")
        if not np.isfinite(shear_exponent):
            raise ModeselError("shear exponent must be finite", field="shear_exponent")
        if not reference_length > 0:
            raise ModeselError(f"reference length must be > 0, got {reference_length}",
                               field="reference_length")
        self.reference_height = float(reference_height)
        self.reference_length = float(reference_length)
        if table is None:
            if time_series is not None:
                series = np.asarray(time_series, float)
                if series.ndim == 2 and series.shape[1] == 2 and series.shape[0] != 2:
                    series = series.T
                if series.ndim != 2 or series.shape[0] != 2 or series.shape[1] < 1:
                    raise ModeselError("time series must be (times, speeds)", field="time_series")
                times, speeds = series
            else:
                times, speeds = np.zeros(1), np.array([float(speed)])
            table = np.zeros((len(times), len(COLUMNS)))
            table[:, 0], table[:, 1] = times, speeds
            table[:, 2] = -float(direction)
            table[:, 5] = float(shear_exponent)
        table = np.asarray(table, float)
        if table.ndim != 2 or table.shape[1] not in (8, 9) or len(table) < 1:
            raise ModeselError("wind table must have 8 or 9 columns", field="time_series")
        if table.shape[1] == 8:
            table = np.column_stack([table, np.zeros(len(table))])
        if not np.all(np.isfinite(table)):
            raise ModeselError("time series has non-finite values", field="time_series")
        if np.any(np.diff(table[:, 0]) <= 0):
            raise ModeselError("time series times must be strictly increasing", field="time_series")
        self.table = table
        self.steady = len(table) == 1
        # the short-form attributes (first row)
        self.speed = float(table[0, 1])
        self.shear_exponent = float(table[0, 5])
        self.direction = float(-table[0, 2])
        self.times = None if self.steady else table[:, 0]
        self.speeds = None if self.steady else table[:, 1]
        self._steady_params = self._params(table[0])
        if full_field is not None:
            packed = full_field.packed()
            self._field = np.concatenate([np.zeros(GRID_SLOT + 1), packed])
            self._field[GRID_SLOT] = GRID_SLOT + 1
            self._field[N_PARAMS - 2:N_PARAMS] = self.turn()

    def turn(self) -> tuple:
        """(cos, sin) of the field's turn, params[12:14] (module doc): the
        upflow of a uniform wind, the direction of a full field."""
        angle = self.direction if self.full_field is not None else self.upflow
        return float(np.cos(angle)), float(np.sin(angle))

    def _params(self, row) -> np.ndarray:
        _, vh, ah, vv, sh, sv, lsv, gust, av = row
        return np.array([vh, np.cos(ah), np.sin(ah), vv, sh, sv, lsv, gust, np.cos(av), np.sin(av),
                         self.reference_height, self.reference_length, np.cos(self.upflow), np.sin(self.upflow)])

    def row(self, t: float) -> np.ndarray:
        """The table row at time t (linear interpolation, ends held)."""
        tab = self.table
        if self.steady or t <= tab[0, 0]:
            return tab[0]
        if t >= tab[-1, 0]:
            return tab[-1]
        return np.array([np.interp(t, tab[:, 0], tab[:, c]) for c in range(tab.shape[1])])

    def params(self, t: float = 0.0) -> np.ndarray:
        """Parameters of `wind_velocity` at time t [s] (N_PARAMS floats; with a
        full field, the field: one array per Wind, its time slot set to t, so
        valid until the next call)."""
        if self.full_field is not None:
            self._field[GRID_SLOT + 1] = float(t)
            return self._field
        if self.steady:
            return self._steady_params
        return self._params(self.row(float(t)))

    def reference_speed(self, t=0.0):
        """VelH(t) [m/s]."""
        if self.steady:
            return np.full(np.shape(t), self.speed) if np.ndim(t) else self.speed
        return np.interp(t, self.table[:, 0], self.table[:, 1])

    def velocity(self, z, t=0.0):
        """Horizontal wind speed V1 [m/s] at heights z [m] on the vertical
        through the origin (broadcast over z and t; no upflow)."""
        z = np.asarray(z, float)
        t = np.asarray(t, float)
        rows = np.array([self.row(float(ti)) for ti in np.atleast_1d(t)])
        if t.ndim == 0:
            rows = rows[0]
        v1 = horizontal_speed(z, 0.0, rows[..., 1], 0.0, rows[..., 5], rows[..., 6], rows[..., 7],
                              self.reference_height, self.reference_length)
        return np.where(z > GROUND, v1, 0.0)

    def vector(self, z, t=0.0, x=0.0, y=0.0):
        """Wind velocity vectors (..., 3) [m/s] at points (x, y, z) and time t
        (numpy; its compiled scalar twin is `wind_velocity`, held equal by
        tests/test_twins.py)."""
        z = np.asarray(z, float)
        x, y = np.broadcast_to(x, z.shape).astype(float), np.broadcast_to(y, z.shape).astype(float)
        if self.full_field is not None:
            c, s = self.turn()
            out = self.full_field.velocity(np.stack([c * x + s * y, -s * x + c * y, z], axis=-1), float(t))
            out = np.stack([c * out[..., 0] - s * out[..., 1], s * out[..., 0] + c * out[..., 1], out[..., 2]],
                           axis=-1)
            return np.where((z > GROUND)[..., None], out, 0.0)
        vh, ch, sh, vv, shr_h, shr_v, lin_v, gust, cv, sv, zr, lr, cu, su = self.params(float(t))
        if su != 0.0:           # the tilted field: the point in its frame (module doc)
            x, z = cu * x + su * (z - zr), zr - su * x + cu * (z - zr)
        above = z > GROUND
        v1 = horizontal_speed(z, y * ch + x * sh, vh, shr_h, shr_v, lin_v, gust, zr, lr)
        v1r = cv * v1 - sv * vv
        out = np.stack([v1r * ch, -v1r * sh, sv * v1 + cv * vv], axis=-1)
        if su != 0.0:
            out = np.stack([cu * out[..., 0] - su * out[..., 2], out[..., 1], su * out[..., 0] + cu * out[..., 2]],
                           axis=-1)
        return np.where(above[..., None], out, 0.0)


def horizontal_speed(z, lateral, vh, shr_h, shr_v, lin_v, gust, zr, lr):
    """V1 [m/s] of the module doc (numpy, broadcast): heights z [m] above
    ground (z <= GROUND gives a finite placeholder; callers zero it), `lateral` =
    y cos AngleH + x sin AngleH [m], the table's VelH, ShrH, ShrV, LinShrV,
    VelGust, RefHt zr [m] and RefLength lr [m]."""
    ratio = np.where(z > GROUND, z, zr) / zr
    return vh * (ratio ** shr_v + (shr_h * lateral + lin_v * (z - zr)) / lr) + gust


@njit(cache=True)
def wind_velocity(p, x, y, z):
    """(u, v, w) [m/s] at (x, y, z) for parameters p = Wind.params(t) (module doc;
    a full field where p[GRID_SLOT] > 0)."""
    if p.shape[0] > GRID_SLOT and p[GRID_SLOT] > 0.0:
        if z <= GROUND:
            return 0.0, 0.0, 0.0
        c, s = p[N_PARAMS - 2], p[N_PARAMS - 1]
        if s == 0.0:
            return grid_velocity(p, int(p[GRID_SLOT]), x, y, z)
        u, v, w = grid_velocity(p, int(p[GRID_SLOT]), c * x + s * y, -s * x + c * y, z)   # the turned field
        return c * u - s * v, s * u + c * v, w
    return uniform_velocity(p, x, y, z)         # the ground: in the tilted field's frame


@njit(cache=True)
def wind_at(p, x, y, z, field):
    """`wind_velocity`, or for field None (numba prunes the branch) the uniform
    wind alone: the compiled loads of a scene without a full field then hold
    no code of it (`effects.compiled.loads_function`)."""
    if field is None:
        return uniform_velocity(p, x, y, z)
    return wind_velocity(p, x, y, z)


@njit(cache=True)
def uniform_velocity(p, x, y, z):
    """(u, v, w) [m/s] of the uniform wind (module doc) at (x, y, z)."""
    vh, ch, sh_, vv, shr_h, shr_v, lin_v, gust, cv, sv, zr, lr = (p[0], p[1], p[2], p[3], p[4], p[5],
                                                                  p[6], p[7], p[8], p[9], p[10], p[11])
    cu, su = p[12], p[13]
    if su != 0.0:               # the tilted field: the point in its frame (module doc)
        x, z = cu * x + su * (z - zr), zr - su * x + cu * (z - zr)
    if z <= GROUND:
        return 0.0, 0.0, 0.0
    v1 = vh * ((z / zr) ** shr_v + (shr_h * (y * ch + x * sh_) + lin_v * (z - zr)) / lr) + gust
    v1r = cv * v1 - sv * vv
    w = sv * v1 + cv * vv
    if su != 0.0:
        return cu * v1r * ch - su * w, -v1r * sh_, su * v1r * ch + cu * w
    return v1r * ch, -v1r * sh_, w


@njit(cache=True)
def wind_params(table, reference_height, reference_length, t, out):
    """Compiled twin of `Wind.params`: the parameters of `wind_velocity` at
    time t [s] into out (N_PARAMS,) from the (N, 9) table (linear
    interpolation in time as np.interp, ends held); out[12:14], the upflow's
    cosine and sine, are not time-dependent and stay as set."""
    n = table.shape[0]
    row = 0
    frac = -1.0
    if n > 1 and t > table[0, 0]:
        if t >= table[n - 1, 0]:
            row = n - 1
        else:
            lo, hi = 0, n - 1
            while hi - lo > 1:
                mid = (lo + hi) >> 1
                if table[mid, 0] <= t:
                    lo = mid
                else:
                    hi = mid
            row = lo
            frac = t - table[lo, 0]
    v = np.empty(9)
    for c in range(9):
        if frac < 0.0:
            v[c] = table[row, c]
        else:
            slope = (table[row + 1, c] - table[row, c]) / (table[row + 1, 0] - table[row, 0])
            v[c] = slope * frac + table[row, c]
    out[0] = v[1]
    out[1] = np.cos(v[2])
    out[2] = np.sin(v[2])
    out[3] = v[3]
    out[4] = v[4]
    out[5] = v[5]
    out[6] = v[6]
    out[7] = v[7]
    out[8] = np.cos(v[8])
    out[9] = np.sin(v[8])
    out[10] = reference_height
    out[11] = reference_length
