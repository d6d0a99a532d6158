"""The tower's influence on the wind the blades see, as AeroDyn models it
(AeroDyn.f90: TwrInfl, getLocalTowerProps, TwrInfl_NearestLine2Element,
TwrInfl_NearestPoint, CalculateTowerInfluence; AeroDyn's TwrPotent and
TwrShadow inputs).

Each blade station is referred to the tower's (deflected) line of AeroDyn
tower nodes: the nearest element onto which the station projects
orthogonally (its point at fraction e between nodes 1 and 2), else the
nearest node. There, with V_rel the wind minus the tower's velocity
(interpolated like the diameter D, drag coefficient Cd and TwrTI), the
tower frame is z along the element (at a node: the end element's
direction), x along the part of V_rel normal to z, y = z x x, and

    W = |V_rel - (V_rel . z) z|,   xbar, ybar = (2 / D) r . x, r . y,

r from the projection (or node) to the station; zbar = 0 on an element.
At the end nodes zbar = (2 / D) r . z and, where |zbar| < 1, xbar and ybar
are divided by cos(pi zbar / 2) (the flow tapers over half a diameter
beyond the tower's ends). The wind at the station gains

    dv = W (u x + v y),   u = u_pot + u_shadow,   v = v_pot,

with, where |zbar| < 1 (eq. numbers are AeroDyn's theory manual's):

- TwrPotent 1, potential flow around a cylinder of radius D/2 in a uniform
  stream W along x: u_pot = (ybar^2 - xbar^2) / (xbar^2 + ybar^2)^2,
  v_pot = -2 xbar ybar / (xbar^2 + ybar^2)^2 (the exact potential flow:
  W (1 + u_pot) is 0 at the stagnation point xbar = -1 and 2 W at the
  cylinder's sides);
- TwrPotent 2 (Bak et al., EWEC 2001): the same with xbar + 0.1, plus the
  source of the tower's drag, Cd xbar / (2 pi (xbar^2 + ybar^2)) on u and
  Cd ybar / (2 pi (xbar^2 + ybar^2)) on v (xbar + 0.1 in both);
- TwrShadow 1 (Powles), downstream only (xbar > 0): with
  d = (xbar^2 + ybar^2)^(1/4), u_shadow = -Cd / d cos^2(pi ybar / (2 d))
  where |ybar| < d;
- TwrShadow 2 (Eames), downstream only: u_shadow = -Cd / (TI xbar
  sqrt(2 pi)) exp(-(ybar / (TI xbar))^2 / 2), TI = TwrTI;

u_shadow no lower than -0.5. A station farther than 20 D from the tower
surface, or closer than D / 100 (inside it), keeps the undisturbed wind.

`TowerInfluence.velocity` is the numpy reference; `tower_disturbance` (numba,
all stations of a rotor) and `_deficit` are the compiled
twins the aero effect uses (effects/aero.py); tests/test_tower_influence.py
holds them equal and checks the potential flow against the cylinder's.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from modesel.errors import ModeselError

#: names of TwrPotent's values 0, 1, 2 (the aero effect's tower_potential option): no potential
#: flow, baseline, with Bak's correction
POTENTIAL_NAMES = ("none", "baseline", "bak")
#: names of TwrShadow's values 0, 1, 2 (the aero effect's tower_shadow option): none, Powles, Eames
SHADOW_NAMES = ("none", "powles", "eames")
#: AeroDyn's EqualRealNos in single precision, for a projection at an element's end
_ON_END = 1.0e-5
#: deficit floor of the shadow (AeroDyn: at most half the wind)
_SHADOW_FLOOR = -0.5


def deficit(potential, shadow, xbar, ybar, zbar, cd, ti):
    """(u, v): the wind's change along x and y per unit W (module doc), numpy
    reference on arrays of xbar, ybar, zbar, Cd, TI."""
    xbar, ybar, zbar, cd, ti = np.broadcast_arrays(*(np.asarray(a, float) for a in (xbar, ybar, zbar, cd, ti)))
    near = np.abs(zbar) < 1.0
    u_pot = np.zeros(xbar.shape)
    v_pot = np.zeros(xbar.shape)
    if potential in (1, 2):
        x = xbar + (0.1 if potential == 2 else 0.0)
        rho2 = x ** 2 + ybar ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            u_pot = np.where(near, (ybar ** 2 - x ** 2) / rho2 ** 2, 0.0)
            v_pot = np.where(near, -2.0 * x * ybar / rho2 ** 2, 0.0)
            if potential == 2:
                u_pot = u_pot + np.where(near, cd * x / (2.0 * np.pi * rho2), 0.0)
                v_pot = v_pot + np.where(near, cd * ybar / (2.0 * np.pi * rho2), 0.0)
    u_sh = np.zeros(xbar.shape)
    behind = near & (xbar > 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        if shadow == 1:
            d = (xbar ** 2 + ybar ** 2) ** 0.25
            u_sh = np.where(behind & (np.abs(ybar) < d), -cd / d * np.cos(0.5 * np.pi * ybar / d) ** 2, 0.0)
        elif shadow == 2:
            s = ti * xbar
            u_sh = np.where(behind, -cd / (s * np.sqrt(2.0 * np.pi)) * np.exp(-0.5 * (ybar / s) ** 2), 0.0)
    return u_pot + np.maximum(u_sh, _SHADOW_FLOOR), v_pot


def check_tower_table(table, potential, shadow, source):
    """The AeroDyn tower table (`TowerDrag` or None) that TwrPotent `potential`
    and TwrShadow `shadow` need: at least 2 nodes, and TwrTI > 0 at every
    node for Eames' shadow; else a one-line ModeselError naming the AeroDyn
    file `source` and the input."""
    if table is None or len(table.elevation) < 2:
        label = "TwrPotent" if potential else "TwrShadow"
        raise ModeselError(f"{label} {potential or shadow} needs a tower table of at least 2 nodes (NumTwrNds)",
                           file=source, field="NumTwrNds")
    if shadow == 2 and (table.turbulence is None or np.any(table.turbulence <= 0.0)):
        raise ModeselError("TwrShadow 2 (Eames) needs TwrTI > 0 at every tower node", file=source, field="TwrTI")


@dataclass(frozen=True)
class TowerInfluence:
    """AeroDyn's tower influence (module doc) on a line of m tower nodes with
    diameters [m], drag coefficients [-] and TwrTI [-] (each (m,))."""

    potential: int
    shadow: int
    diameter: np.ndarray
    drag_coefficient: np.ndarray
    turbulence: np.ndarray

    def local(self, point, pos, vel, wind):
        """AeroDyn's tower frame at a station `point` (3,) [m] (module doc)
        from the tower nodes' positions `pos`, velocities `vel` and wind
        `wind` (m, 3) [m, m/s]: (frame (3, 3) with columns x, y, z; W [m/s];
        xbar, ybar, zbar; Cd; TI; D [m]; clearance [m] from the tower's surface)."""
        point, pos, vel, wind = (np.asarray(a, float) for a in (point, pos, vel, wind))
        rel = wind - vel
        d = np.diff(pos, axis=0)
        lengths2 = np.einsum("ij,ij->i", d, d)
        e = np.einsum("ij,ij->i", d, point - pos[:-1]) / lengths2
        e = np.where((e < 0.0) & (e > -_ON_END), 0.0, np.where((e > 1.0) & (e < 1.0 + _ON_END), 1.0, e))
        on = (e >= 0.0) & (e <= 1.0)
        if on.any():
            r_all = point - (pos[:-1] + e[:, None] * d)
            dist = np.where(on, np.einsum("ij,ij->i", r_all, r_all), np.inf)
            j = int(np.argmin(dist))
            w = np.array([1.0 - e[j], e[j]])
            r = r_all[j]
            at = lambda a: w @ a[j:j + 2]                               # noqa: E731
            z_axis = d[j] / np.sqrt(lengths2[j])
            end = False
        else:
            j = int(np.argmin(np.einsum("ij,ij->i", point - pos, point - pos)))
            r = point - pos[j]
            at = lambda a: a[j]                                         # noqa: E731
            k = min(j, len(d) - 1)
            z_axis = d[k] / np.sqrt(lengths2[k])
            end = j in (0, len(pos) - 1)
        diam, cd, ti, v_rel = at(self.diameter), at(self.drag_coefficient), at(self.turbulence), at(rel)
        normal = v_rel - (v_rel @ z_axis) * z_axis
        W = float(np.linalg.norm(normal))
        clearance = float(np.linalg.norm(r)) - 0.5 * diam
        if W == 0.0:
            return np.zeros((3, 3)), 0.0, 1.0, 0.0, 0.0, cd, ti, diam, clearance
        x_axis = normal / W
        y_axis = np.cross(z_axis, v_rel) / W
        xbar, ybar, zbar = 2.0 / diam * (r @ x_axis), 2.0 / diam * (r @ y_axis), 0.0
        if end:
            zbar = 2.0 / diam * (r @ z_axis)
            if abs(zbar) < 1.0:
                taper = np.cos(0.5 * np.pi * zbar)
                xbar, ybar = xbar / taper, ybar / taper
            else:
                xbar, ybar = 1.0, 0.0
        return np.column_stack([x_axis, y_axis, z_axis]), W, xbar, ybar, zbar, cd, ti, diam, clearance

    def velocity(self, points, pos, vel, wind):
        """The wind's change dv (..., 3) [m/s] at stations `points` (..., 3)
        [m] (module doc), numpy reference of `tower_disturbance`."""
        points = np.asarray(points, float)
        out = np.zeros(points.shape)
        flat_in, flat_out = points.reshape(-1, 3), out.reshape(-1, 3)
        for i, point in enumerate(flat_in):
            frame, W, xbar, ybar, zbar, cd, ti, diam, clearance = self.local(point, pos, vel, wind)
            if clearance > 20.0 * diam or clearance <= 0.01 * diam:
                continue
            u, v = deficit(self.potential, self.shadow, xbar, ybar, zbar, cd, ti)
            flat_out[i] = frame @ np.array([float(u) * W, float(v) * W, 0.0])
        return out

    def packed(self) -> np.ndarray:
        """(3 m,) floats of the compiled twin: diameters, Cd, TI."""
        return np.concatenate([self.diameter, self.drag_coefficient, self.turbulence]).astype(float)


@njit(cache=True)
def _deficit(potential, shadow, xbar, ybar, zbar, cd, ti):
    """Compiled twin of `deficit` for one station: (u, v)."""
    u = 0.0
    v = 0.0
    if abs(zbar) >= 1.0:
        return u, v
    if potential == 1 or potential == 2:
        x = xbar + 0.1 if potential == 2 else xbar
        rho2 = x * x + ybar * ybar
        u = (ybar * ybar - x * x) / (rho2 * rho2)
        v = -2.0 * x * ybar / (rho2 * rho2)
        if potential == 2:
            u += cd * x / (2.0 * np.pi * rho2)
            v += cd * ybar / (2.0 * np.pi * rho2)
    sh = 0.0
    if xbar > 0.0:
        if shadow == 1:
            d = np.sqrt(np.sqrt(xbar * xbar + ybar * ybar))
            if abs(ybar) < d:
                c = np.cos(0.5 * np.pi * ybar / d)
                sh = -cd / d * c * c
        elif shadow == 2:
            s = ti * xbar
            sh = -cd / (s * np.sqrt(2.0 * np.pi)) * np.exp(-0.5 * (ybar / s) * (ybar / s))
    return u + max(sh, _SHADOW_FLOOR), v


@njit(cache=True)
def tower_disturbance(potential, shadow, stations, pos, vel, wind, props, dist):
    """Compiled twin of `TowerInfluence.velocity`: the wind's change dv [m/s]
    at every station (B, M, 3) [m] into dist (B, M, 3), from the tower
    nodes' positions, velocities and wind pos, vel, wind (m, 3) and props =
    `TowerInfluence.packed` (one function, not one per station: numba
    optimises a callee again inside each caller's module)."""
    pts = stations.reshape((-1, 3))
    out = dist.reshape((-1, 3))
    for i in range(pts.shape[0]):
        px, py, pz = pts[i, 0], pts[i, 1], pts[i, 2]
        out[i, 0] = 0.0
        out[i, 1] = 0.0
        out[i, 2] = 0.0
        m = pos.shape[0]
        best = np.inf
        j = -1
        e_j = 0.0
        for k in range(m - 1):
            d0, d1, d2 = pos[k + 1, 0] - pos[k, 0], pos[k + 1, 1] - pos[k, 1], pos[k + 1, 2] - pos[k, 2]
            e = (d0 * (px - pos[k, 0]) + d1 * (py - pos[k, 1]) + d2 * (pz - pos[k, 2])) / (d0 * d0 + d1 * d1 + d2 * d2)
            if -_ON_END < e < 0.0:
                e = 0.0
            elif 1.0 < e < 1.0 + _ON_END:
                e = 1.0
            if e < 0.0 or e > 1.0:
                continue
            r0, r1, r2 = px - pos[k, 0] - e * d0, py - pos[k, 1] - e * d1, pz - pos[k, 2] - e * d2
            gap = r0 * r0 + r1 * r1 + r2 * r2
            if gap < best:
                best = gap
                j = k
                e_j = e
        end = False
        if j >= 0:
            w0, w1 = 1.0 - e_j, e_j
            a, b, k = j, j + 1, j
        else:
            for n in range(m):
                r0, r1, r2 = px - pos[n, 0], py - pos[n, 1], pz - pos[n, 2]
                gap = r0 * r0 + r1 * r1 + r2 * r2
                if gap < best:
                    best = gap
                    j = n
            w0, w1 = 1.0, 0.0
            a, b, k = j, j, min(j, m - 2)
            end = j == 0 or j == m - 1
        r0 = px - w0 * pos[a, 0] - w1 * pos[b, 0]
        r1 = py - w0 * pos[a, 1] - w1 * pos[b, 1]
        r2 = pz - w0 * pos[a, 2] - w1 * pos[b, 2]
        diam = w0 * props[a] + w1 * props[b]
        cd = w0 * props[m + a] + w1 * props[m + b]
        ti = w0 * props[2 * m + a] + w1 * props[2 * m + b]
        v0 = w0 * (wind[a, 0] - vel[a, 0]) + w1 * (wind[b, 0] - vel[b, 0])
        v1 = w0 * (wind[a, 1] - vel[a, 1]) + w1 * (wind[b, 1] - vel[b, 1])
        v2 = w0 * (wind[a, 2] - vel[a, 2]) + w1 * (wind[b, 2] - vel[b, 2])
        z0, z1, z2 = pos[k + 1, 0] - pos[k, 0], pos[k + 1, 1] - pos[k, 1], pos[k + 1, 2] - pos[k, 2]
        zz = np.sqrt(z0 * z0 + z1 * z1 + z2 * z2)
        z0, z1, z2 = z0 / zz, z1 / zz, z2 / zz
        clearance = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2) - 0.5 * diam
        if clearance > 20.0 * diam or clearance <= 0.01 * diam:
            continue
        vz = v0 * z0 + v1 * z1 + v2 * z2
        n0, n1, n2 = v0 - vz * z0, v1 - vz * z1, v2 - vz * z2
        W = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if W == 0.0:
            continue
        x0, x1, x2 = n0 / W, n1 / W, n2 / W
        y0, y1, y2 = (z1 * v2 - z2 * v1) / W, (z2 * v0 - z0 * v2) / W, (z0 * v1 - z1 * v0) / W
        xbar = 2.0 / diam * (r0 * x0 + r1 * x1 + r2 * x2)
        ybar = 2.0 / diam * (r0 * y0 + r1 * y1 + r2 * y2)
        zbar = 0.0
        if end:
            zbar = 2.0 / diam * (r0 * z0 + r1 * z1 + r2 * z2)
            if abs(zbar) < 1.0:
                taper = np.cos(0.5 * np.pi * zbar)
                xbar /= taper
                ybar /= taper
            else:
                xbar, ybar = 1.0, 0.0
        u, v = _deficit(potential, shadow, xbar, ybar, zbar, cd, ti)
        out[i, 0] = W * (u * x0 + v * y0)
        out[i, 1] = W * (u * x1 + v * y1)
        out[i, 2] = W * (u * x2 + v * y2)
