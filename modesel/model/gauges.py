"""ElastoDyn's strain-gauge loads. Blades: Spn<i>FLxb<b>, Spn<i>FLyb<b>,
Spn<i>FLzb<b> [kN] and Spn<i>MLxb<b>, Spn<i>MLyb<b>, Spn<i>MLzb<b> [kN m], the
force and moment that the part of blade b outboard of gauge i exerts on the
section at ElastoDyn node BldGagNd(i), in the section's own axes
(ElastoDyn.f90 CalcOutput, "Blade Local Span Loads").

Force summation over ElastoDyn's nodes, as ElastoDyn sums them: each node j
outboard of the gauge node g carries T_j = F_j + m_j g - m_j a_j (F_j the
effects' node force, m_j the node mass, g gravity, a_j the node's inertial
acceleration) and its node moment, the tip mass its weight and inertia, and
half the gauge node's element its half of T_g at 1/4 of the element length
outboard along the blade's pitched axis j3:

    F = T_tip + sum_{j>g} T_j + T_g / 2
    M = (r_tip - r_g) x T_tip + sum_{j>g} ((r_j - r_g) x T_j + M_j)
        + (DR_g / 4 j3) x (T_g / 2) + M_g / 2

On blades with AeroDyn, F_j and M_j are the aerodynamic loads as OpenFAST's
mesh mapping hands them to ElastoDyn's nodes (each lumped piece of AeroDyn's
line on its nearest node, `BladeAerodynamics.openfast_node_loads`), not the
transfer the integration uses (a lumped station load shared between its two
neighbouring nodes): both keep the blade's total force and moment, but split
a station's load differently at a gauge (Spn3MLyb1's mean +2.7 % with the latter).

The axes (ElastoDyn's n1, n2, n3 of node g): the pitched blade axes turned
about j3 by the structural twist (Lxb, Lyb), then by SmllRotTrans of the
section's slopes (ThetaLxb, ThetaLyb, 0), ThetaIP = -slope_y and ThetaOoP =
slope_x of the elastic displacement in the pitched frame, with ThetaLxb =
cos(twist) ThetaIP - sin(twist) ThetaOoP and ThetaLyb = sin(twist) ThetaIP +
cos(twist) ThetaOoP.

Tower (TwHt<i>FLxt, FLyt, FLzt [kN], TwHt<i>MLxt, MLyt, MLzt [kN m], "Tower
Local Loads"): the same sum over the tower nodes above gauge TwrGagNd(i),
started with the loads the nacelle and rotor exert on the yaw bearing
(YawBrF*p, YawBrM*p: the reaction loads, which the yaw-bearing mass is not
part of), less the yaw-bearing mass's weight and inertia, with the half
element's arm DHNodes / 4 along the vertical; axes t of the gauge node:
SmllRotTrans(ThetaSS, 0, ThetaFA) of ElastoDyn's tower-base axes (a1 = x,
a2 = z, a3 = -y), ThetaFA = -slope_FA, ThetaSS = slope_SS; FLxt = F . t1,
FLyt = -F . t3, FLzt = F . t2. Written on ElastoDyn's tower nodes with a
fixed tower base.

Motions at the gauge nodes, as ElastoDyn writes them: Spn<i>TDxb<b> ...
TDzb [m], the node's displacement from its undeflected place on the pitch
axis in the pitched frame j; Spn<i>RDxb, RDyb [deg], ThetaIP and ThetaOoP;
Spn<i>ALxb ... ALzb [m/s^2], its acceleration in the section's axes n, and
ALgxb ... the same less gravity's (an accelerometer's); the tower's
TwHt<i>TDxt ... on a1, -a3, a2, RDxt = ThetaSS, RDyt = -ThetaFA, ALxt ...
on t1, -t3, t2.

Blade tips (ElastoDyn's "Blade (1-3) Tip Motions"): TipALxb<b> ... TipALzb
and TipALgxb ... [m/s^2], the tip's acceleration (and less gravity's) in the
axes n of the last node (BldNodes); TipRDxb, TipRDyb [deg], ThetaIP and
ThetaOoP of the tip's slopes; TipClrnc<b> (= TwrClrnc<b>) [m], from the
tower top to the tip: its distance where the tip is above the yaw bearing,
else its distance from the yaw axis (the nacelle frame's x and y).

The accelerations are those of the solved equations: a_j = dv_j/dt along the
state's own motion, (v_j(q + h qd, qd + h qdd) - v_j(q - h qd, qd - h qdd)) /
2h, h = 1e-5 s (exact to O(h^2)). Written where the blade is integrated on
ElastoDyn's nodes (an OpenFAST case's): the frames at the three states of
every output time in three compiled calls, the points' motions, sums and
projections for all times at once, and one evaluation of the effects per
output time where a gauge needs loads.
"""
from __future__ import annotations

import re

import numpy as np

from modesel.multibody.kinematics import PointSet
from modesel.multibody.rotations import cross, small_rotation

#: a blade gauge channel: gauge i, quantity (FL force, ML moment, TD deflection,
#: RD rotation, AL acceleration, ALg with gravity), axis, blade b
GAUGE_CHANNEL = re.compile(r"Spn([1-9])(FL|ML|TD|RD|ALg|AL)([xyz])b([1-9])")
#: a tower gauge channel: gauge i, quantity, axis
TOWER_GAUGE_CHANNEL = re.compile(r"TwHt([1-9])(FL|ML|TD|RD|ALg|AL)([xyz])t")
#: a blade-tip motion channel: quantity (AL, ALg, RD), axis, blade; or TipClrnc, blade
TIP_CHANNEL = re.compile(r"Tip(ALg|AL|RD)([xyz])b([1-9])|TipClrnc([1-9])")
#: the tip channels ElastoDyn writes per blade
TIP_QUANTITIES = [f"Tip{k}{a}b" for k in ("AL", "ALg") for a in "xyz"] + ["TipRDxb", "TipRDyb", "TipClrnc"]
#: the gauge quantities' units
GAUGE_UNITS = {"FL": "kN", "ML": "kN-m", "TD": "m", "RD": "deg", "AL": "m/s^2", "ALg": "m/s^2"}
#: the quantities and axes ElastoDyn writes (no rotation about the beam's axis)
GAUGE_QUANTITIES = [(k, a) for k in ("FL", "ML", "TD", "AL", "ALg") for a in "xyz"] + [("RD", "x"), ("RD", "y")]
#: the yaw bearing's loads a tower gauge starts from
YAW_BEARING_LOADS = ("YawBrFxp", "YawBrFyp", "YawBrFzp", "YawBrMxp", "YawBrMyp", "YawBrMzp")
#: time step of the acceleration's central difference [s]
STEP = 1e-5


def gauge_channels(turbine) -> list:
    """The gauge channels the deck's blade gauges (NBlGages, BldGagNd) allow."""
    return [f"Spn{i}{k}{a}b{b}" for b in range(1, turbine.num_blades + 1)
            for i in range(1, len(turbine.blade_gauges) + 1) for k, a in GAUGE_QUANTITIES]


def wanted_gauges(model, wanted) -> dict:
    """{blade: sorted gauge numbers} of the gauge channels in `wanted` (None:
    all the deck has), where the blades are on ElastoDyn's nodes."""
    if not model.blade_elastodyn_nodes or not model.turbine.blade_gauges:
        return {}
    names = gauge_channels(model.turbine) if wanted is None else wanted
    out = {}
    for name in names:
        m = GAUGE_CHANNEL.fullmatch(name)
        if m and int(m.group(1)) <= len(model.turbine.blade_gauges) and \
                int(m.group(4)) <= model.turbine.num_blades and f"blade{m.group(4)}" in model.tips:
            out.setdefault(int(m.group(4)), set()).add(int(m.group(1)))
    return {b: sorted(g) for b, g in out.items()}


def wanted_tips(model, wanted) -> list:
    """The blades (numbers) whose tip channels `wanted` names (None: every
    blade), where the blades are on ElastoDyn's nodes."""
    if not model.blade_elastodyn_nodes:
        return []
    blades = [b for b in range(1, model.turbine.num_blades + 1) if f"blade{b}" in model.tips]
    if wanted is None:
        return blades
    found = {int(m.group(3) or m.group(4)) for n in wanted if (m := TIP_CHANNEL.fullmatch(n))}
    return [b for b in blades if b in found]


class _States:
    """The states at the output times: every time's point positions `pos`
    and accelerations `acc` (n, M, 3) of the point sets `sets` {key:
    PointSet} (the acceleration by the central difference, module doc), the
    bodies' rotations `R` (n, bodies, 3, 3), origins `origin` and the
    origins' accelerations `origin_acc` (n, bodies, 3): the frames at every
    output time's state and its two neighbours along the motion come from
    three compiled calls (`FrameCache.along`), the points' motions from the
    numpy reference at all times at once (`PointSet.along`). `at(k)`
    evaluates the effects' loads at output time k: one evaluation per time,
    shared by the blade and tower gauges."""

    def __init__(self, built, integ, accelerations, sets):
        self.built, self.integ = built, integ
        eq = built.eq
        free = list(built.model.system.free)
        n = len(integ.t)
        full = [eq.full_state(integ.q[k], integ.qd[k], integ.t[k]) for k in range(n)]
        self.Q = np.array([f[0] for f in full]).reshape(n, eq.n_all)
        self.QD = np.array([f[1] for f in full]).reshape(n, eq.n_all)
        QDD = np.array([f[2] for f in full]).reshape(n, eq.n_all)
        if free:
            QDD[:, eq.free_idx] = np.column_stack([accelerations[c] for c in free])
        cache = built.frame_cache
        self.frames = cache.along(self.Q, self.QD)
        moved = {sign: (self.Q + sign * STEP * self.QD, self.QD + sign * STEP * QDD) for sign in (1.0, -1.0)}
        moved_frames = {sign: cache.along(*state) for sign, state in moved.items()}
        self.pos = {key: ps.along(self.frames, self.Q, self.QD)[0] for key, ps in sets.items()}
        velocity = {sign: {key: ps.along(moved_frames[sign], *moved[sign])[1] for key, ps in sets.items()}
                    for sign in moved}
        self.acc = {key: (velocity[1.0][key] - velocity[-1.0][key]) / (2.0 * STEP) for key in sets}
        self.R, self.origin = self.frames[0], self.frames[1][:, :, 0]
        self.origin_acc = (moved_frames[1.0][1][:, :, 1] - moved_frames[-1.0][1][:, :, 1]) / (2.0 * STEP)

    def at(self, k):
        """The effects' node loads {body: (N, 6) [N, N m]} at output time k (kept)."""
        q_all, qd_all = self.Q[k], self.QD[k]
        self.built.frame_cache.hold(q_all, qd_all, (self.frames[0][k], self.frames[1][k]))   # the effects' frames
        _, applied = self.built.loads(self.integ.t[k], q_all, qd_all)
        return {name: np.array(v) for name, v in applied.items()}


def gauge_loads(built, integ, accelerations, blade_gauges, tower_gauges, yaw_bearing, tips=()) -> dict:
    """The gauge channels of `blade_gauges` {blade: gauge numbers} and
    `tower_gauges` (gauge numbers), and the tip channels of blades `tips`
    (module doc) at the output times of `integ`; accelerations: {free
    coordinate: qdd}; yaw_bearing: the YAW_BEARING_LOADS histories [kN, kN m]
    (for the tower's). The motions come for all times at once (`_States`);
    one pass over the output times gathers the effects' loads where a gauge
    needs them (`collect`); the channels follow for all times at once (`channels`)."""
    eq = built.eq
    n = len(integ.t)
    sets = {f"blade{b}": PointSet.of_body(eq, f"blade{b}") for b in blade_gauges}
    if tower_gauges:
        sets["tower"] = PointSet.of_body(eq, "tower")
    for b in tips:
        sets[f"tip{b}"] = _tip_points(built, b)
    states = _States(built, integ, accelerations, sets)
    aero = built.effect("aero")
    aero = aero if aero is not None and hasattr(aero, "augmented") else None
    loaded = ([_BladeGauges(built, blade_gauges, aero, n)] if blade_gauges else []) + \
        ([_TowerGauges(built, tower_gauges, yaw_bearing, n)] if tower_gauges else [])
    for k in range(n if loaded else 0):
        applied = states.at(k)
        for part in loaded:
            part.collect(applied, k)
    out = {}
    for part in loaded + ([_Tips(built, tips)] if tips else []):
        out.update(part.channels(states))
    return out


def _rows(A, v):
    """A[k] @ v[k] for each time k: A (n, 3, 3), v (n, 3)."""
    return np.einsum("kij,kj->ki", A, v)


def _section(load, pos, g, outer, arm, axes, force0=None, moment0=None):
    """The force and moment (module doc) at node g at each time from the
    node loads `load` (n, N, 6) of the nodes `outer` beyond it and half of
    g's (the half element's arm `arm` (n, 3)), started from force0 and
    moment0 (n, 3); and their components on `axes` (n, 3, 3), in kN and kN m."""
    force = load[:, outer, :3].sum(axis=1) + 0.5 * load[:, g, :3]
    moment = (cross(pos[:, outer] - pos[:, g, None], load[:, outer, :3]).sum(axis=1) + load[:, outer, 3:].sum(axis=1)
              + cross(arm, 0.5 * load[:, g, :3]) + 0.5 * load[:, g, 3:])
    if force0 is not None:
        force, moment = force + force0, moment + moment0
    return _rows(axes, force) / 1e3, _rows(axes, moment) / 1e3


def _tip_points(built, b):
    """blade b's tip as a point set: at the blade length on its axis, its
    displacement per coordinate and shortening as the model's tip has them."""
    eq = built.eq
    body = eq.system.body(f"blade{b}")
    tip = built.model.tips[f"blade{b}"]
    phi = np.zeros((1, 3, body.n_elastic))
    shortening = np.zeros((1, body.n_elastic, body.n_elastic))
    for j, dof in enumerate(body.dofs):
        phi[0, :, j] = tip["displacement"].get(dof, 0.0)
    if tip.get("shortening") is not None:
        dofs, G = tip["shortening"]
        at = [list(body.dofs).index(d) for d in dofs]
        shortening[0][np.ix_(at, at)] = np.asarray(G, float)
    return PointSet.of_points(eq, f"blade{b}", np.array([[0.0, 0.0, tip["length"]]]), phi, shortening)


def _section_axes(R, twist, slope, qe):
    """ElastoDyn's axes n (rows) of a blade section (module doc) and its
    (ThetaIP, ThetaOoP) [rad] at each time: the pitched frame R (n, 3, 3)'s
    axes turned by the structural twist, then by the small rotation of the
    slopes `slope` (3, ne) at coordinates qe (n, ne)."""
    c, s = np.cos(twist), np.sin(twist)
    j1, j2, j3 = R[:, :, 0], R[:, :, 1], R[:, :, 2]
    lj = np.stack([c * j1 - s * j2, s * j1 + c * j2, j3], axis=1)
    theta_ip, theta_oop = _slope_angles(slope, qe)
    return small_rotation(c * theta_ip - s * theta_oop, s * theta_ip + c * theta_oop) @ lj, theta_ip, theta_oop


def _slope_angles(slope, qe) -> tuple:
    """(ThetaIP, ThetaOoP) [rad] of a blade section at each time: -slope_y
    and slope_x of the elastic displacement, `slope` (3, ne) per coordinate,
    at coordinates qe (n, ne)."""
    if not qe.shape[1]:
        return np.zeros(len(qe)), np.zeros(len(qe))
    sx, sy = (qe @ slope.T)[:, :2].T
    return -sy, sx


class _Tips:
    """The blade tips' channels (module doc)."""

    def __init__(self, built, blades):
        self.built, self.blades = built, blades
        model, eq = built.model, built.eq
        turbine = model.turbine
        self.gravity = np.array([0.0, 0.0, -turbine.gravity])
        nodes = int(turbine.blade_nodes)
        blade = turbine.blade
        self.index = {b: eq.body_index[f"blade{b}"] for b in blades}
        self.idx = {b: PointSet.of_body(eq, f"blade{b}").idx for b in blades}
        last = PointSet.of_body(eq, f"blade{blades[0]}").s0[nodes - 1, 2]
        self.last = (np.interp(last, blade.span - blade.span[0], blade.twist),
                     {b: model.station_slopes(f"blade{b}", np.array([last]))[0] for b in blades})
        self.tip_slope = {b: model.station_slopes(f"blade{b}", np.array([blade.length]))[0] for b in blades}
        self.nacelle = eq.body_index["nacelle"]      # its origin is the tower top (ElastoDyn's point O)

    def channels(self, st):
        out = {}
        R_n, r_top = st.R[:, self.nacelle], st.origin[:, self.nacelle]
        for b in self.blades:
            qe, acc, pos = st.Q[:, self.idx[b]], st.acc[f"tip{b}"][:, 0], st.pos[f"tip{b}"][:, 0]
            axes, _, _ = _section_axes(st.R[:, self.index[b]], self.last[0], self.last[1][b], qe)
            theta_ip, theta_oop = _slope_angles(self.tip_slope[b], qe)
            al, alg = _rows(axes, acc), _rows(axes, acc - self.gravity)
            for i, a in enumerate("xyz"):
                out[f"TipAL{a}b{b}"], out[f"TipALg{a}b{b}"] = al[:, i], alg[:, i]
            out[f"TipRDxb{b}"], out[f"TipRDyb{b}"] = np.degrees(theta_ip), np.degrees(theta_oop)
            x, y, z = np.einsum("kji,kj->ik", R_n, pos - r_top)      # R_n^T (tip - top)
            out[f"TipClrnc{b}"] = np.where(z > 0.0, np.sqrt(x * x + y * y + z * z), np.hypot(x, y))
        return out


class _BladeGauges:
    """The blade gauges' channels (module doc)."""

    def __init__(self, built, gauges, aero, n):
        self.built, self.gauges, self.aero = built, gauges, aero
        turbine = built.model.turbine
        self.gravity = np.array([0.0, 0.0, -turbine.gravity])
        self.nodes = int(turbine.blade_nodes)
        self.dr = turbine.blade.length / self.nodes
        eq = built.eq
        self.mass = {b: np.asarray(eq.system.body(f"blade{b}").node_mass, float) for b in gauges}
        self.index = {b: eq.body_index[f"blade{b}"] for b in gauges}
        ps = {b: PointSet.of_body(eq, f"blade{b}") for b in gauges}
        self.idx = {b: ps[b].idx for b in gauges}
        self.slopes = {b: built.model.station_slopes(f"blade{b}", ps[b].s0[:self.nodes, 2]) for b in gauges}
        blade = turbine.blade
        self.twist = {b: np.interp(ps[b].s0[:self.nodes, 2], blade.span - blade.span[0], blade.twist)
                      for b in gauges}
        self.span = {b: ps[b].s0[:self.nodes, 2] for b in gauges}         # ElastoDyn's RNodes from the root
        self.load = {b: np.zeros((n, len(self.mass[b]), 6)) for b in gauges}
        # with AeroDyn: its line loads at each time (`BladeAerodynamics.line_state`)
        self.line = None if aero is None else [np.empty((n,) + a.shape) for a in aero.line_state()]

    def collect(self, applied, k):
        if self.aero is not None:
            for keep, now in zip(self.line, self.aero.line_state()):
                keep[k] = now
            return
        for b in self.gauges:
            f = applied.get(f"blade{b}")
            if f is not None:
                self.load[b][k, :len(f), :f.shape[1]] = f

    def channels(self, st):
        out = {}
        for b, gs in self.gauges.items():
            name = f"blade{b}"
            load, pos, acc, R = self.load[b].copy(), st.pos[name], st.acc[name], st.R[:, self.index[b]]
            if self.aero is not None:
                load[:, :self.nodes] = self.aero.openfast_node_loads(b - 1, pos[:, :self.nodes], self.line)
            load[:, :, :3] += self.mass[b][None, :, None] * (self.gravity - acc)
            j3 = R[:, :, 2]
            qe = st.Q[:, self.idx[b]]
            for i in gs:
                g = self.built.model.turbine.blade_gauges[i - 1] - 1
                axes, theta_ip, theta_oop = _section_axes(R, self.twist[b][g], self.slopes[b][g], qe)
                f, m = _section(load, pos, g, np.arange(g + 1, load.shape[1]), 0.25 * self.dr * j3, axes)
                # motions: the node's displacement from its undeflected place in the pitched
                # frame (TD), its slopes' rotation (RD: ThetaIP, ThetaOoP), its acceleration
                # in the section's axes, without and with gravity's (AL, ALg: a - g)
                moved = pos[:, g] - st.origin[:, self.index[b]] - self.span[b][g] * j3
                values = {"FL": f, "ML": m, "TD": np.einsum("kji,kj->ki", R, moved),     # R^T moved
                          "AL": _rows(axes, acc[:, g]), "ALg": _rows(axes, acc[:, g] - self.gravity),
                          "RD": np.degrees(np.column_stack([theta_ip, theta_oop, np.zeros(len(R))]))}
                for q, a in GAUGE_QUANTITIES:
                    out[f"Spn{i}{q}{a}b{b}"] = values[q][:, "xyz".index(a)]
        return out


def wanted_tower_gauges(model, wanted) -> list:
    """Sorted tower gauge numbers of the gauge channels in `wanted` (None:
    all the deck has), where the tower is on ElastoDyn's nodes, its base
    fixed and the yaw bearing a body of its own (`reaction_forces`)."""
    gauges = model.turbine.tower_gauges
    if not gauges or not model.tower_elastodyn_nodes or not any(b.name == "yaw_bearing" for b in model.system.bodies):
        return []
    if any(d in ("PtfmSurge", "PtfmPitch") for d in (*model.system.free, *model.system.prescribed)):
        return []
    if wanted is None:
        return list(range(1, len(gauges) + 1))
    found = {int(m.group(1)) for n in wanted if (m := TOWER_GAUGE_CHANNEL.fullmatch(n))}
    return sorted(i for i in found if i <= len(gauges))


class _TowerGauges:
    """The tower gauges' channels (module doc)."""

    def __init__(self, built, gauges, yaw_bearing, n):
        self.built, self.gauges, self.yaw_bearing = built, gauges, yaw_bearing
        model, eq = built.model, built.eq
        turbine = model.turbine
        self.gravity = np.array([0.0, 0.0, -turbine.gravity])
        self.nodes = int(turbine.tower_nodes)
        self.dh = turbine.tower.length / self.nodes
        self.mass = np.asarray(eq.system.body("tower").node_mass, float)[:self.nodes]
        self.top = eq.body_index["yaw_bearing"]
        self.root = eq.body_index["tower"]
        self.base = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])   # a1, a2, a3
        self.height = PointSet.of_body(eq, "tower").s0[:self.nodes, 2]     # ElastoDyn's HNodes
        x = self.height / turbine.tower.length
        self.slope = {}
        for fld in ("tower_fa", "tower_ss"):
            dofs = model.field_dofs.get(fld, ())
            if dofs:
                self.slope[fld] = (model.shapes[fld](x).dphi / turbine.tower.length, [eq.index[d] for d in dofs])
        self.load = np.zeros((n, self.nodes, 6))

    @staticmethod
    def _angle(slope, q_all, g):
        if slope is None:
            return np.zeros(len(q_all))
        shape, idx = slope
        return q_all[:, idx] @ shape[:, g]

    def collect(self, applied, k):
        f = applied.get("tower")
        if f is not None:
            self.load[k, :, :f.shape[1]] = f[:self.nodes]

    def channels(self, st):
        turbine = self.built.model.turbine
        n = self.nodes
        load, pos, acc = self.load.copy(), st.pos["tower"][:, :n], st.acc["tower"][:, :n]     # the applied loads kept
        R_p, r_top, origin = st.R[:, self.top], st.origin[:, self.top], st.origin[:, self.root]
        load[:, :, :3] += self.mass[None, :, None] * (self.gravity - acc)
        f_top = _rows(R_p, np.column_stack([self.yaw_bearing[c] for c in YAW_BEARING_LOADS[:3]]) * 1e3)
        m_top = _rows(R_p, np.column_stack([self.yaw_bearing[c] for c in YAW_BEARING_LOADS[3:]]) * 1e3)
        f_top = f_top + turbine.yaw_bearing_mass * (self.gravity - st.origin_acc[:, self.top])
        arm = np.broadcast_to(0.25 * self.dh * self.base[1], (len(load), 3))
        out = {}
        for i in self.gauges:
            g = turbine.tower_gauges[i - 1] - 1
            theta_fa = -self._angle(self.slope.get("tower_fa"), st.Q, g)
            theta_ss = self._angle(self.slope.get("tower_ss"), st.Q, g)
            t = small_rotation(theta_ss, np.zeros_like(theta_ss), theta_fa) @ self.base
            axes = np.stack([t[:, 0], -t[:, 2], t[:, 1]], axis=1)   # FLxt = F . t1, FLyt = -F . t3, FLzt = F . t2
            f, m = _section(load, pos, g, np.arange(g + 1, n), arm, axes,
                            f_top, cross(r_top - pos[:, g], f_top) + m_top)
            # motions (ElastoDyn's rTPT on a1, -a3, a2; AngPosXF: ThetaSS, -ThetaFA; LinAccET on t)
            moved = pos[:, g] - origin - self.height[g] * self.base[1]
            values = {"FL": f, "ML": m, "TD": moved @ self.base[[0, 2, 1]].T * np.array([1.0, -1.0, 1.0]),
                      "AL": _rows(axes, acc[:, g]), "ALg": _rows(axes, acc[:, g] - self.gravity),
                      "RD": np.degrees(np.column_stack([theta_ss, -theta_fa, np.zeros(len(load))]))}
            for q, a in GAUGE_QUANTITIES:
                out[f"TwHt{i}{q}{a}t"] = values[q][:, "xyz".index(a)]
        return out
