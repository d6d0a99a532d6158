"""Blade aerodynamics by quasi-steady BEM on the moving, deflecting blades
(second paper section 3: BEM with Prandtl tip/hub loss, Buhl/Glauert and
Pitt-Peters skew; the work of the loads, eq. 52, enters as node forces).

    [effects.aero]
    aerodyn = "path/to/AeroDyn.dat"   # default for the built-in nrel5mw: its bundled deck
    skew = true                       # Pitt-Peters (default: the deck's SkewMod)

Needs [effects.wind]. At every right-hand side:

1. Stations: the AeroDyn blade nodes (BlSpn), as points of each flexible
   blade with the blade's own mode shapes evaluated there
   (`TurbineModel.station_shapes`); their inertial positions and
   velocities include all structural motion (tower, nacelle, rotor speed,
   blade vibration) through the engine's kinematics (`kinematics.py`).
2. Inflow: v_rel = wind(z, t) - v_station. With x_s the shaft axis (hub
   frame x) and z_b the blade's (coned, undeflected) axis, the element
   normal is e_n = unit(x_s - (x_s . z_b) z_b) (downwind, normal to the
   coned blade) and the direction of rotation e_t = e_n x z_b; then
   V_n = v_rel . e_n and V_t = -v_rel . e_t (rotor speed times radius plus
   the blade's own in-plane motion). The element radius is the undeflected
   r = (HubRad + BlSpn) cos(precone), as in `aero.steady_rotor`.
3. Skew (Pitt-Peters): chi_0 is the angle between x_s and the hub-height
   wind relative to the hub (wind at the apex minus the hub velocity), so a
   shaft tilt, a yaw error or nacelle motion skew the wake; psi is each
   blade's azimuth from the in-plane direction of that relative wind.
4. BEM for all blades and stations at once -> f_n, f_t [N/m]:
   `BemSolver.solve_into` on buffers preallocated once (`StationBem`;
   `solve` allocates its result at every call, which costs as much as the
   solution itself here).
5. Loads: f = f_n e_n + f_t e_t per unit length at the stations,
   interpolated linearly in span to the blade's quadrature nodes and
   multiplied by the node quadrature weights w_k [m]: node force
   F_k = f(s_k) w_k, applied at the deflected node. The sectional pitching
   moment is not applied (the blades have no torsion DOF).
   On ElastoDyn's discrete blade nodes (`elastodyn_nodes`, a handful of
   midpoints that a midpoint rule on f would under-resolve near the tip)
   the transfer follows OpenFAST's mesh mapping instead: the AeroDyn line
   loads (linear between stations) are lumped to point loads at the
   stations, F_a = int N_a f ds (hat functions N_a), and each is carried to
   the structural nodes by the transpose of the linear interpolation (and
   extrapolation beyond the first and last node) along the span, which
   keeps the total force and its moment about the root and does the same
   virtual work as F_a at r_a on the piecewise-linear blade line
   (`_lumped_transfer`).

Channels (AeroDyn's names and units, see `channels`): RtAeroFxh [N] = sum
of node forces along x_s, RtAeroMxh [N m] = sum of their moments about x_s
through the apex (the loads the structure receives), RtAeroPwr [W],
RtAeroCp [-]. (ElastoDyn's RotThrust and RotTorq are the shaft loads,
inertia and weight included: outputs.py.)

Options beyond the deck: `air_density` replaces the deck's AirDens (an
OpenFAST case passes the .fst AirDens where the deck says "default").
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
from numba import njit

from modesel.errors import ModeselError
from modesel.model.effects.base import Effect, Option
from modesel.aero.wind import wind_velocity
from modesel.multibody.kinematics import PointSet


@functools.lru_cache(maxsize=8)
def _read_deck(path: str):
    from modesel.turbine.aerodyn import read_aerodyn
    return read_aerodyn(path)


def aerodyn_deck(effect):
    """The AeroDyn deck of an effect's `aerodyn` option (default: the
    built-in turbine's bundled deck)."""
    path = effect.options.get("aerodyn")
    if path is None:
        from modesel.turbine.builtin import builtin_aerodyn_for
        bundled = builtin_aerodyn_for(effect.scene.turbine.source or "")
        if bundled is None:
            raise effect.error("give the AeroDyn deck: aerodyn = \"path\" (relative to the scene)", "aerodyn")
        path = str(bundled)
    if not Path(path).is_file():
        raise ModeselError("AeroDyn file not found", file=path, field=f"effects.{effect.name}.aerodyn")
    return _read_deck(str(Path(path).resolve()))


def wind_of(effect, built):
    """The scene's wind field (the `wind` effect), or a user error."""
    wind = built.effect("wind")
    if wind is None:
        raise effect.error("needs a wind: add [effects.wind]")
    return wind.field


class BladeAerodynamics(Effect):
    name = "aero"
    loads = True
    OPTIONS = {
        "aerodyn": Option("path", None, "AeroDyn main file"),
        "skew": Option("bool", None, "Pitt-Peters skewed-wake correction"),
        "air_density": Option("number", None, "air density [kg/m^3] (default: the deck's)", positive=True),
    }

    def setup(self, built):
        from modesel.aero.bem import BemOptions, BemSolver
        model, eq, t = built.model, built.eq, built.model.turbine
        self.wind = wind_of(self, built)
        deck = aerodyn_deck(self)
        self.deck = deck
        over = {} if self.options["skew"] is None else {"skew_correction": self.options["skew"]}
        span = deck.blade.span
        if abs(span[-1] - t.blade.length) > 0.01 * t.blade.length:
            raise self.error(f"the AeroDyn blade ({span[-1]:g} m) and the structural blade "
                             f"({t.blade.length:g} m) differ in length", "aerodyn")
        solver = BemSolver.from_blade(deck.blade, span, num_blades=t.num_blades, hub_radius=t.hub_radius,
                                           precone=float(t.precone[0]),
                                      air_density=(deck.air_density if self.options["air_density"] is None
                                                   else self.options["air_density"]),
                                           options=BemOptions.from_deck(deck, **over))
        B, M = t.num_blades, len(span)
        self.bem = StationBem(solver, B)
        self.names = [f"blade{b}" for b in range(1, B + 1)]
        self.stations = []
        self.nodes = []
        for name in self.names:
            s0, Phi, S = model.station_shapes(name, span)
            self.stations.append(PointSet.of_points(eq, name, s0, Phi, S))
            self.nodes.append(PointSet.of_body(eq, name))
        self.r = np.broadcast_to((t.hub_radius + span) * np.cos(np.asarray(t.precone[:B], float))[:, None],
                                 (B, M)).copy()
        nodes_span = self.nodes[0].s0[:, 2]
        self.weights = np.asarray(model.weights[self.names[0]], float)
        if model.blade_elastodyn_nodes:
            self.transfer = _lumped_transfer(span, nodes_span, self.weights > 0)
        else:
            self.transfer = _sampled_transfer(span, nodes_span, self.weights)
        self.hub = eq.body_index["hub"]
        self.blades = np.array([eq.body_index[n] for n in self.names], dtype=np.int64)
        self.pitch = model.pitch
        self.pos = np.empty((B, M, 3))
        self.vel = np.empty((B, M, 3))
        self.vrel = np.empty(3)
        self.vn, self.vt, self.skew, self.psi = (np.empty((B, M)) for _ in range(4))
        self.en = np.empty((B, 3))
        self.et = np.empty((B, 3))
        self.forces = np.empty((B, len(nodes_span), 3))
        self.rmax = float(self.r.max())

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        frames = built.frames(q_all, qd_all)
        for b, st in enumerate(self.stations):
            st.kinematics(frames, q_all, qd_all, self.pos[b], self.vel[b])
        R, vec = frames
        inflow(R, vec, self.hub, self.blades, self.pos, self.vel, self.wind.params(t),
               self.vn, self.vt, self.skew, self.psi, self.en, self.et, self.vrel)
        fn, ft = self.bem(self.r, self.vn, self.vt, self.pitch, self.skew, self.psi)
        distribute(fn, ft, self.en, self.et, self.transfer, self.forces)
        for b, name in enumerate(self.names):      # self.forces is overwritten at the next call
            f = node_forces.get(name)
            node_forces[name] = self.forces[b] if f is None else f + self.forces[b]
        self.last = {"q": q_all, "qd": qd_all, "v_dot_x": float(self.vrel @ R[self.hub][:, 0])}

    def compile_loads(self, built, packer, node_start):
        """Pack this effect for the compiled loop (`effects.compiled`): the
        same arrays `__call__` uses, and `solve_into`'s arguments."""
        from modesel.model.effects.packing import AERO, point_set_ints
        B, M = self.r.shape
        N = self.forces.shape[1]
        s, buf = self.bem.solver, self.bem.buffers
        o = s.options
        grid, value, slope = s.polars.arrays
        o_const = packer.add([s.num_blades, s.tip_radius, s.hub_radius, s.air_density, o.skew_factor,
                              o.tolerance])
        o_elem = packer.add(np.concatenate([self.r.ravel(), np.add(self.pitch, buf.twist).ravel(),
                                            buf.chord.ravel()]))
        o_T = packer.add(self.transfer)
        o_pol = packer.add(np.concatenate([grid, value.ravel(), slope.ravel()]))
        o_scr = packer.scratch(B * M * 3 * 2 + 4 * B * M + 6 * B + 3 + 13 * B * M + B * N * 3)
        ints = [self.hub, B, M, N, o_const, o_elem, o_T, o_pol, grid.size, value.shape[1], o_scr]
        ints += list(self.blades) + [node_start[n][0] for n in self.names] + list(buf.offset.ravel())
        for st in self.stations:
            ints += point_set_ints(packer, st)
        ints += [o.tip_loss, o.hub_loss, o.tangential_induction, o.axial_drag, o.tangential_drag,
                 o.skew_correction, o.max_iterations]
        packer.record(AERO, ints)

    def channels(self, built):
        """AeroDyn's rotor channels (AeroDyn_IO.f90): RtAeroFxh [N] and
        RtAeroMxh [N m], the blade loads' force along and moment about the
        hub x axis (through the apex); RtAeroPwr [W] = RtAeroMxh * rotor
        speed; RtAeroCp = RtAeroPwr / (1/2 rho RtArea V^3), V the
        disk-averaged relative wind along the hub x axis (`V_dot_x`: wind
        minus blade velocity, averaged over the stations), RtArea = pi rmax^2
        with rmax the largest station radius."""
        if not self.last:
            return {}
        frames = built.frames(self.last["q"], self.last["qd"])
        R, vec = frames
        thrust = torque = 0.0
        for b, nodes in enumerate(self.nodes):
            pos, _ = nodes.kinematics(frames, self.last["q"], self.last["qd"])
            f, m = rotor_loads(self.forces[b], pos, R[self.hub], vec[self.hub, 0])
            thrust += f
            torque += m
        omega = float(vec[self.hub, 2] @ R[self.hub][:, 0])
        power = torque * omega
        v = self.last["v_dot_x"]
        area = np.pi * self.rmax**2
        cp = power / (0.5 * self.bem.solver.air_density * area * v**3) if abs(v) >= 0.04 else 0.0
        return {"RtAeroFxh": thrust, "RtAeroMxh": torque, "RtAeroPwr": power, "RtAeroCp": cp}


class StationBem:
    """`solver` on a fixed (n_blades, n_stations) element set: (f_n, f_t)
    [N/m] by `BemSolver.solve_into` into buffers allocated once (views,
    overwritten by the next call)."""

    def __init__(self, solver, n_blades):
        self.solver = solver
        self.buffers = solver.allocate((n_blades, solver.chord.size))

    def __call__(self, r, vn, vt, pitch, skew, psi):
        self.solver.solve_into(self.buffers, r, vn, vt, pitch, skew, psi)
        return self.buffers.f_n, self.buffers.f_t


@njit(cache=True)
def rotor_loads(forces, pos, R_hub, apex):
    """(thrust along the shaft x_s, torque about it through the apex) of node forces."""
    thrust = 0.0
    torque = 0.0
    for i in range(forces.shape[0]):
        f = forces[i]
        d0, d1, d2 = pos[i, 0] - apex[0], pos[i, 1] - apex[1], pos[i, 2] - apex[2]
        m0, m1, m2 = d1 * f[2] - d2 * f[1], d2 * f[0] - d0 * f[2], d0 * f[1] - d1 * f[0]
        thrust += f[0] * R_hub[0, 0] + f[1] * R_hub[1, 0] + f[2] * R_hub[2, 0]
        torque += m0 * R_hub[0, 0] + m1 * R_hub[1, 0] + m2 * R_hub[2, 0]
    return thrust, torque

def _sampled_transfer(stations, at, weights):
    """(nodes, stations) matrix T: node force = sum_a T[i, a] f_a with f
    interpolated linearly to the node and times its weight (module doc 5)."""
    lo, frac = _linear_weights(stations, at)
    T = np.zeros((len(at), len(stations)))
    rows = np.arange(len(at))
    T[rows, lo] += (1.0 - frac) * weights
    T[rows, lo + 1] += frac * weights
    return T


def _lumped_transfer(stations, at, structural):
    """(nodes, stations) matrix T of the lumped transfer (module doc 5):
    L (stations, stations) lumps the piecewise-linear line load to point
    loads, F_a = sum over the two adjacent elements of h (2 f_a + f_b) / 6;
    W (nodes, stations) is the transpose of the linear interpolation of the
    `structural` nodes' positions to the stations (end elements extrapolated),
    so sum_i W[i, a] = 1 and sum_i W[i, a] z_i = z_a."""
    stations = np.asarray(stations, float)
    h = np.diff(stations)
    Lmp = np.zeros((len(stations), len(stations)))
    for k, hk in enumerate(h):
        Lmp[k, k] += hk / 3.0
        Lmp[k, k + 1] += hk / 6.0
        Lmp[k + 1, k + 1] += hk / 3.0
        Lmp[k + 1, k] += hk / 6.0
    idx = np.flatnonzero(structural)
    z = np.asarray(at, float)[idx]
    W = np.zeros((len(at), len(stations)))
    if len(idx) == 1:
        W[idx[0], :] = 1.0
        return W @ Lmp
    lo = np.clip(np.searchsorted(z, stations, side="right") - 1, 0, len(z) - 2)
    a = (stations - z[lo]) / (z[lo + 1] - z[lo])
    cols = np.arange(len(stations))
    W[idx[lo], cols] += 1.0 - a
    W[idx[lo + 1], cols] += a
    return W @ Lmp


def _linear_weights(stations, at):
    """Index lo and fraction so that f(at) = (1-frac) f[lo] + frac f[lo+1]
    (linear interpolation between stations, ends held)."""
    at = np.clip(at, stations[0], stations[-1])
    lo = np.clip(np.searchsorted(stations, at, side="right") - 1, 0, len(stations) - 2)
    frac = (at - stations[lo]) / (stations[lo + 1] - stations[lo])
    return lo.astype(np.int64), frac


@njit(cache=True)
def inflow(R, vec, hub, blades, pos, vel, wp, vn, vt, skew, psi, en, et, vrel):
    """Element inflow (module doc, steps 2-3) for all blades and stations;
    wp = `Wind.params(t)`. vrel receives the disk-averaged relative wind
    (wind minus station velocity, averaged over all stations)."""
    xs = R[hub, :, 0]
    apex, vhub = vec[hub, 0], vec[hub, 1]
    u0, u1, u2 = wind_velocity(wp, apex[0], apex[1], apex[2])
    w0, w1, w2 = u0 - vhub[0], u1 - vhub[1], u2 - vhub[2]
    wa = w0 * xs[0] + w1 * xs[1] + w2 * xs[2]
    p0, p1, p2 = w0 - wa * xs[0], w1 - wa * xs[1], w2 - wa * xs[2]
    wp_ = np.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    chi0 = np.arctan2(wp_, wa)
    vrel[0] = 0.0
    vrel[1] = 0.0
    vrel[2] = 0.0
    for b in range(blades.shape[0]):
        zb = R[blades[b], :, 2]
        c = xs[0] * zb[0] + xs[1] * zb[1] + xs[2] * zb[2]
        n0, n1, n2 = xs[0] - c * zb[0], xs[1] - c * zb[1], xs[2] - c * zb[2]
        nn = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        n0, n1, n2 = n0 / nn, n1 / nn, n2 / nn
        t0, t1, t2 = n1 * zb[2] - n2 * zb[1], n2 * zb[0] - n0 * zb[2], n0 * zb[1] - n1 * zb[0]
        en[b, 0], en[b, 1], en[b, 2] = n0, n1, n2
        et[b, 0], et[b, 1], et[b, 2] = t0, t1, t2
        # blade azimuth from the in-plane relative wind (Pitt-Peters psi)
        r0, r1, r2 = zb[0] - c * xs[0], zb[1] - c * xs[1], zb[2] - c * xs[2]
        rr = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        psi_b = 0.0
        if wp_ > 0.0:
            cp = (r0 * p0 + r1 * p1 + r2 * p2) / (rr * wp_)
            psi_b = np.arccos(min(1.0, max(-1.0, cp)))
        for k in range(pos.shape[1]):
            uk0, uk1, uk2 = wind_velocity(wp, pos[b, k, 0], pos[b, k, 1], pos[b, k, 2])
            v0 = uk0 - vel[b, k, 0]
            v1 = uk1 - vel[b, k, 1]
            v2 = uk2 - vel[b, k, 2]
            vrel[0] += v0
            vrel[1] += v1
            vrel[2] += v2
            vn[b, k] = v0 * n0 + v1 * n1 + v2 * n2
            vt[b, k] = -(v0 * t0 + v1 * t1 + v2 * t2)
            skew[b, k] = chi0
            psi[b, k] = psi_b
    n = blades.shape[0] * pos.shape[1]
    vrel[0] /= n
    vrel[1] /= n
    vrel[2] /= n


@njit(cache=True)
def distribute(fn, ft, en, et, T, out):
    """Node forces out[b, i] = sum_a T[i, a] (f_n,a e_n + f_t,a e_t) from the
    loads per unit length at the stations (module doc, step 5)."""
    for b in range(out.shape[0]):
        for i in range(out.shape[1]):
            n = 0.0
            t = 0.0
            for a in range(T.shape[1]):
                n += T[i, a] * fn[b, a]
                t += T[i, a] * ft[b, a]
            for c in range(3):
                out[b, i, c] = n * en[b, c] + t * et[b, c]


EFFECT = BladeAerodynamics
