"""Full-field turbulent wind: InflowWind's Grid3D field read from a TurbSim
binary file (WindType 3; OpenFAST `InflowWind_IO.f90` IfW_TurbSim_Init,
`IfW_FlowField.f90` Grid3DField_GetCell / Grid3DField_GetVelLinear).

The file holds the three velocity components [m/s] on a vertical grid of
NY x NZ points (spacing dy, dz [m], centred laterally on y = 0, bottom row
at GridBase [m]) at NSteps instants dt [s] apart, plus NTGrids points on
the tower's axis below the grid (tower point k, 1-based, at
GridBase - (k - 1) dz). The grid is frozen turbulence carried downwind at
the mean hub-height speed MWS: a point (x, y, z) at time t reads the grid
at the shifted time

    T = t + (InitXPosition - x) / MWS

(InitXPosition = half the grid width for a non-periodic file, ID 7, so
that at t = 0 a point that far downstream reads the first instant; 0 for a
periodic one, ID 8, whose time wraps around). The velocity is trilinear in
(y, z, T) inside the grid (points within 1e-3 of a cell of its edge snap
to it, InflowWind's GridTol); below the grid it is linear in (z, T) along
the tower points, and from the last tower point linearly to zero at the
ground; at or below the ground it is zero. Anywhere else (above or beside
the grid, below it without tower points, beyond the file's time) InflowWind
stops with an error; here the velocity is NaN, which the integration
reports as a divergence (`FullField.check_covers` names the file first
where the rotor at rest already leaves it). Beyond the last instant by less
than dt, InflowWind holds the last instant for T within half a step of it
and otherwise interpolates over the last interval with the fraction past
the last instant; so does this module.

Values are (int16 - offset) / slope in single precision, as InflowWind
stores them (SiKi); the interpolation runs in double precision.

`read_turbsim(path)` -> `FullField`: `velocity(points, t)` (numpy, the
reference) and `packed()`, the flat array the compiled twin
`grid_velocity(p, g, x, y, z)` reads (header `HEADER` floats at p[g:],
the current time first, then the grid and the tower points).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit

from modesel.errors import ModeselError

#: InflowWind's GridTol: a point this close (in cells) to the grid's edge is on it
GRID_TOL = 1e-3
#: TurbSim file IDs: 7 non-periodic, 8 periodic
NON_PERIODIC, PERIODIC = 7, 8
#: floats before the data in `FullField.packed()`: time, ny, nz, n_tower, n_steps,
#: dy, dz, rate, half width, grid base, InitXPosition, 1/MWS, periodic
HEADER = 13
#: the largest field this reader accepts (points x steps x 3 components): 480 MB in the
#: compiled loads' state (doubles), e.g. 31 x 31 points at 0.05 s for 1000 s
MAX_VALUES = 60_000_000

_HEAD = np.dtype([("id", "<i2"), ("nz", "<i4"), ("ny", "<i4"), ("ntw", "<i4"), ("nt", "<i4"),
                  ("dz", "<f4"), ("dy", "<f4"), ("dt", "<f4"), ("mws", "<f4"), ("zhub", "<f4"),
                  ("zbottom", "<f4"), ("scale", "<f4", (6,)), ("nchar", "<i4")])


@dataclass(frozen=True, eq=False)
class FullField:
    """A TurbSim full field (module doc). Arrays in SI units, single
    precision as InflowWind holds them: grid (NSteps, NZ, NY, 3) and tower
    (NSteps, NTGrids, 3) [m/s]."""
    grid: np.ndarray
    tower: np.ndarray
    dy: float
    dz: float
    dt: float
    mean_speed: float
    hub_height: float
    grid_base: float
    periodic: bool
    source: str = ""

    @property
    def half_width(self) -> float:
        """YHWid [m]: half the grid's width."""
        return 0.5 * (self.grid.shape[2] - 1) * self.dy

    @property
    def top(self) -> float:
        """Height [m] of the grid's top row."""
        return self.grid_base + (self.grid.shape[1] - 1) * self.dz

    @property
    def init_x(self) -> float:
        """InitXPosition [m] (module doc)."""
        return 0.0 if self.periodic else self.half_width

    @property
    def duration(self) -> float:
        """The shifted time T [s] the file covers: [0, duration]."""
        n = self.grid.shape[0]
        return n * self.dt if self.periodic else (n - 1) * self.dt

    def packed(self) -> np.ndarray:
        """Header and data as `grid_velocity` reads them (module doc), time 0."""
        nt, nz, ny, _ = self.grid.shape
        head = [0.0, ny, nz, self.tower.shape[1], nt, self.dy, self.dz, 1.0 / self.dt, self.half_width,
                self.grid_base, self.init_x, 1.0 / self.mean_speed, float(self.periodic)]
        return np.concatenate([np.array(head, float), self.grid.ravel(), self.tower.ravel()])

    def check_covers(self, hub_height: float, radius: float, tmax: float, field: str = "grid", turn: float = 0.0):
        """A one-line ModeselError where the rotor disc at rest (centre at
        hub_height [m] on the tower's axis, radius [m]) leaves the grid, or
        where the file's time ends before tmax [s] at the hub (a
        non-periodic file; with the field turned by `turn` [rad] about the
        vertical, `aero.wind`, at the disc's most upwind point in the
        field's frame); InflowWind stops there too."""
        if hub_height + radius > self.top + GRID_TOL * self.dz:
            raise ModeselError(f"the grid's top row is at {self.top:g} m; the rotor reaches "
                               f"{hub_height + radius:g} m", file=self.source, field=field)
        if hub_height - radius < self.grid_base - GRID_TOL * self.dz and self.tower.shape[1] == 0:
            raise ModeselError(f"the grid's bottom row is at {self.grid_base:g} m and the file has no "
                               f"tower points; the rotor reaches down to {hub_height - radius:g} m",
                               file=self.source, field=field)
        if radius > self.half_width + GRID_TOL * self.dy:
            raise ModeselError(f"the grid is {2 * self.half_width:g} m wide; the rotor "
                               f"{2 * radius:g} m", file=self.source, field=field)
        need = tmax + (self.init_x + radius * abs(np.sin(turn))) / self.mean_speed
        if not self.periodic and need > self.duration:
            raise ModeselError(f"the file covers {self.duration:g} s of frozen turbulence; a run of "
                               f"{tmax:g} s at {self.mean_speed:g} m/s needs {need:g} s at the hub",
                               file=self.source, field=field)

    def velocity(self, points, t: float) -> np.ndarray:
        """Wind velocity (..., 3) [m/s] at inertial points (..., 3) [m] at time
        t [s] (numpy reference of `grid_velocity`, module doc)."""
        pts = np.asarray(points, float)
        shape = pts.shape[:-1]
        x, y, z = (pts.reshape(-1, 3)[:, i] for i in range(3))
        out = np.full((x.size, 3), np.nan)
        nt, nz, ny, _ = self.grid.shape
        ntw = self.tower.shape[1]
        # time: cell (k0, k1) and weight w1 of k1
        shifted = t + (self.init_x - x) / self.mean_speed
        tg = shifted / self.dt
        if self.periodic:
            tg = np.mod(np.mod(tg, nt), nt)
        k0 = np.floor(tg).astype(np.int64)
        frac = tg - np.trunc(tg)
        k1 = k0 + 1
        last = k0 == nt - 1
        ok_t = ((k0 >= 0) & (k1 <= nt - 1)) | last
        if self.periodic:
            k1 = np.where(last, 0, k1)
        else:
            hold = last & (2 * frac - 1 <= GRID_TOL)
            k1 = np.where(hold, k0, k1)
            frac = np.where(hold, 0.0, frac)
            back = last & ~hold                      # InflowWind's last-interval fraction
            k0, k1 = np.where(back, nt - 2, k0), np.where(back, nt - 1, k1)
        # heights and lateral positions on the grid
        zg = (z - self.grid_base) / self.dz
        yg = (y + self.half_width) / self.dy
        i0, fy = _cell(yg, ny)
        j0, fz = _cell(zg, nz)
        inside = ok_t & (i0 >= 0) & (j0 >= 0)
        k0c, k1c = np.clip(k0, 0, nt - 1), np.clip(k1, 0, nt - 1)
        i0c, j0c = np.clip(i0, 0, ny - 2), np.clip(j0, 0, nz - 2)
        g = self.grid
        v = np.zeros((x.size, 3))
        for kk, wt in ((k0c, 1.0 - frac), (k1c, frac)):
            for dj, wz in ((0, 1.0 - fz), (1, fz)):
                for di, wy in ((0, 1.0 - fy), (1, fy)):
                    v += (wt * wz * wy)[:, None] * g[kk, j0c + dj, i0c + di]
        out[inside] = v[inside]
        below = ok_t & (zg < 0) & (j0 < 0) & (z > 0) & (ntw > 0)
        if np.any(below):
            depth = (self.grid_base - z[below]) / self.dz          # tower points below the top one
            m0 = np.floor(depth).astype(np.int64)
            fm = depth - m0
            on_tower = m0 < ntw - 1
            tw = self.tower
            kb0, kb1, ftb = k0c[below], k1c[below], frac[below]
            lower = np.where(on_tower, m0 + 1, ntw - 1)
            m0 = np.minimum(m0, ntw - 1)
            # from the last tower point to the ground: weight of the point by height
            z_last = max(self.grid_base - (ntw - 1) * self.dz, 1e-300)   # > 0 where it is reached
            fm = np.where(on_tower, fm, 1.0 - z[below] / z_last)
            w_lower = np.where(on_tower, 1.0, 0.0)
            vb = np.zeros((below.sum(), 3))
            for kk, wt in ((kb0, 1.0 - ftb), (kb1, ftb)):
                vb += ((1.0 - fm) * wt)[:, None] * tw[kk, m0]
                vb += (fm * wt * w_lower)[:, None] * tw[kk, lower]
            out[below] = vb
        out[z <= 0.0] = 0.0
        return out.reshape(shape + (3,))


def _cell(coord, n):
    """Lower index and fraction of grid coordinates `coord` (0 at the first
    point) on n points; index -1 outside (module doc: GridTol snaps)."""
    i = np.floor(coord).astype(np.int64)
    f = coord - i
    i = np.where((i == -1) & (f >= 1.0 - GRID_TOL), 0, i)
    f = np.where((coord < 0) & (i == 0), 0.0, f)
    snap_top = (i == n - 1) & (f <= GRID_TOL)
    i = np.where(snap_top, n - 2, i)
    f = np.where(snap_top, 1.0, f)
    return np.where((i >= 0) & (i <= n - 2), i, -1), f


@njit(cache=True)
def _bound(coord, n):
    """Scalar `_cell`: (lower index or -1 outside, fraction)."""
    i = np.floor(coord)
    f = coord - i
    k = int(i)
    if k == -1 and f >= 1.0 - GRID_TOL:
        return 0, 0.0
    if k == n - 1 and f <= GRID_TOL:
        return n - 2, 1.0
    if k < 0 or k > n - 2:
        return -1, f
    return k, f


@njit(cache=True)
def grid_velocity(p, g, x, y, z):
    """(u, v, w) [m/s] at (x, y, z) [m] of the full field packed at p[g:]
    (`FullField.packed`, its time slot set to the current time; module doc);
    NaN outside the field."""
    nan = np.nan
    if z <= 0.0:
        return 0.0, 0.0, 0.0
    t = p[g]
    ny, nz, ntw, nt = int(p[g + 1]), int(p[g + 2]), int(p[g + 3]), int(p[g + 4])
    dy, dz, rate, half, base = p[g + 5], p[g + 6], p[g + 7], p[g + 8], p[g + 9]
    init_x, inv_mws, periodic = p[g + 10], p[g + 11], p[g + 12] != 0.0
    data = g + HEADER
    tower = data + nt * nz * ny * 3
    tg = (t + (init_x - x) * inv_mws) * rate
    if periodic:
        tg = tg - np.floor(tg / nt) * nt
        if tg >= nt:
            tg -= nt
    kf = np.floor(tg)
    k0 = int(kf)
    frac = tg - np.trunc(tg)
    k1 = k0 + 1
    if k0 == nt - 1:
        if periodic:
            k1 = 0
        elif 2.0 * frac - 1.0 <= GRID_TOL:
            k1, frac = k0, 0.0
        else:
            k0, k1 = nt - 2, nt - 1
    elif k0 < 0 or k1 > nt - 1:
        return nan, nan, nan
    zg = (z - base) / dz
    j0, fz = _bound(zg, nz)
    if j0 >= 0:
        i0, fy = _bound((y + half) / dy, ny)
        if i0 < 0:
            return nan, nan, nan
        u0 = u1 = u2 = 0.0
        for a in range(2):
            kk = k0 if a == 0 else k1
            wt = 1.0 - frac if a == 0 else frac
            for b in range(2):
                wz = (1.0 - fz if b == 0 else fz) * wt
                for c in range(2):
                    w = (1.0 - fy if c == 0 else fy) * wz
                    o = data + (((kk * nz) + j0 + b) * ny + i0 + c) * 3
                    u0 += w * p[o]
                    u1 += w * p[o + 1]
                    u2 += w * p[o + 2]
        return u0, u1, u2
    if zg >= 0.0 or ntw == 0:
        return nan, nan, nan
    depth = (base - z) / dz
    m0 = int(np.floor(depth))
    if m0 < ntw - 1:
        fm = depth - m0
        m1, w1 = m0 + 1, 1.0
    else:
        m0 = ntw - 1
        fm = 1.0 - z / (base - (ntw - 1) * dz)
        m1, w1 = m0, 0.0
    u0 = u1 = u2 = 0.0
    for a in range(2):
        kk = k0 if a == 0 else k1
        wt = 1.0 - frac if a == 0 else frac
        o0 = tower + (kk * ntw + m0) * 3
        o1 = tower + (kk * ntw + m1) * 3
        w0, wl = (1.0 - fm) * wt, fm * wt * w1
        u0 += w0 * p[o0] + wl * p[o1]
        u1 += w0 * p[o0 + 1] + wl * p[o1 + 1]
        u2 += w0 * p[o0 + 2] + wl * p[o1 + 2]
    return u0, u1, u2


def read_turbsim(path) -> FullField:
    """A TurbSim binary full-field file (.bts; module doc), or a one-line
    ModeselError naming the file and what is wrong with it."""
    path = Path(path)
    src = str(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ModeselError(f"cannot read the TurbSim file: {exc.strerror}", file=src,
                           field="FileName_BTS") from None
    if len(raw) < _HEAD.itemsize:
        raise ModeselError(f"{len(raw)} bytes: shorter than a TurbSim header ({_HEAD.itemsize})",
                           file=src, field="header")
    h = np.frombuffer(raw, _HEAD, count=1)[0]
    fid, nz, ny, ntw, nt = (int(h[k]) for k in ("id", "nz", "ny", "ntw", "nt"))
    if fid not in (NON_PERIODIC, PERIODIC):
        raise ModeselError(f"file ID {fid}: not a TurbSim full-field file (7 or 8)", file=src, field="header")
    if min(ny, nz, nt) < 2 or ntw < 0:
        raise ModeselError(f"grid of {ny} x {nz} points, {ntw} tower points, {nt} steps: needs at least "
                           "2 x 2 points and 2 steps", file=src, field="header")
    if (ny * nz + ntw) * nt * 3 > MAX_VALUES:
        raise ModeselError(f"{ny} x {nz} points and {ntw} tower points at {nt} steps: more than "
                           f"{MAX_VALUES} values", file=src, field="header")
    dz, dy, dt, mws, zhub, zbottom = (float(h[k]) for k in ("dz", "dy", "dt", "mws", "zhub", "zbottom"))
    for name, value in (("dy", dy), ("dz", dz), ("dt", dt), ("mean wind speed", mws)):
        if not (np.isfinite(value) and value > 0):
            raise ModeselError(f"{name} must be > 0, got {value:g}", file=src, field="header")
    if not (np.isfinite(zbottom) and zbottom > 0):
        raise ModeselError(f"grid bottom must be above the ground, got {zbottom:g} m", file=src, field="header")
    scale = h["scale"].astype(np.float32)
    slope, offset = scale[0::2], scale[1::2]
    if not (np.all(np.isfinite(scale)) and np.all(slope != 0)):
        raise ModeselError("scaling slopes must be finite and non-zero", file=src, field="header")
    start = _HEAD.itemsize + int(h["nchar"])
    per_step = (ny * nz + ntw) * 3
    if int(h["nchar"]) < 0 or len(raw) < start + 2 * per_step * nt:
        raise ModeselError(f"{len(raw)} bytes: the header announces {nt} steps of {ny} x {nz} points and "
                           f"{ntw} tower points ({start + 2 * per_step * nt} bytes)", file=src, field="data")
    data = np.frombuffer(raw, "<i2", count=per_step * nt, offset=start).reshape(nt, per_step)
    values = (data.astype(np.float32).reshape(nt, -1, 3) - offset) / slope      # single precision (SiKi)
    grid = np.ascontiguousarray(values[:, :ny * nz].reshape(nt, nz, ny, 3))
    tower = np.ascontiguousarray(values[:, ny * nz:].reshape(nt, ntw, 3))
    return FullField(grid, tower, dy, dz, dt, mws, zhub, zbottom, fid == PERIODIC, src)


def write_turbsim(path, grid, tower, dy, dz, dt, mean_speed, hub_height, grid_base, periodic=False,
                  description="modesel"):
    """Write a TurbSim binary file (the layout `read_turbsim` reads): grid
    (NSteps, NZ, NY, 3) and tower (NSteps, NTGrids, 3) [m/s], scaled per
    component to the int16 range as TurbSim does."""
    grid = np.asarray(grid, float)
    tower = np.asarray(tower, float).reshape(grid.shape[0], -1, 3)
    nt, nz, ny, _ = grid.shape
    both = np.concatenate([grid.reshape(nt, -1, 3), tower], axis=1)
    lo, hi = both.min(axis=(0, 1)), both.max(axis=(0, 1))
    span = np.where(hi > lo, hi - lo, 1.0)
    slope = (2.0 * 32000.0 / span).astype(np.float32)
    offset = (-32000.0 - lo * slope).astype(np.float32)
    text = description.encode("ascii", "replace")
    head = np.zeros(1, _HEAD)
    head[0] = (PERIODIC if periodic else NON_PERIODIC, nz, ny, tower.shape[1], nt, dz, dy, dt, mean_speed,
               hub_height, grid_base, np.ravel(np.column_stack([slope, offset])), len(text))
    ints = np.clip(np.rint(both * slope + offset), -32768, 32767).astype("<i2")
    Path(path).write_bytes(head.tobytes() + text + ints.tobytes())
