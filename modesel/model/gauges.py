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

The accelerations are those of the solved equations: a_j = dv_j/dt along the
state's own motion, (v_j(q + h qd, qd + h qdd) - v_j(q - h qd, qd - h qdd)) /
2h, h = 1e-5 s (exact to O(h^2)). Written where the blade is integrated on
ElastoDyn's nodes (an OpenFAST case's), one evaluation of the effects and
three of the kinematics per output time.
"""
from __future__ import annotations

import re

import numpy as np

from modesel.multibody.kinematics import PointSet

#: a blade gauge channel: gauge i, F (force) or M (moment), axis, blade b
GAUGE_CHANNEL = re.compile(r"Spn([1-9])([FM])L([xyz])b([1-9])")
#: a tower gauge channel: gauge i, F or M, axis
TOWER_GAUGE_CHANNEL = re.compile(r"TwHt([1-9])([FM])L([xyz])t")
#: the yaw bearing's loads a tower gauge starts from
YAW_BEARING_LOADS = ("YawBrFxp", "YawBrFyp", "YawBrFzp", "YawBrMxp", "YawBrMyp", "YawBrMzp")
#: time step of the acceleration's central difference [s]
STEP = 1e-5


def gauge_channels(turbine) -> list:
    """The gauge channels the deck's blade gauges (NBlGages, BldGagNd) allow."""
    return [f"Spn{i}{k}L{a}b{b}" for b in range(1, turbine.num_blades + 1)
            for i in range(1, len(turbine.blade_gauges) + 1) for k in "FM" for a in "xyz"]


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


def small_rotation(t1, t2, t3=0.0) -> np.ndarray:
    """ElastoDyn's SmllRotTrans (NWTC_Num.f90): the orthonormal matrix of
    the small rotation (t1, t2, t3) [rad] about x1, x2, x3 (rows: the turned
    axes in the old ones)."""
    w = np.sqrt(1.0 - 0.25 * (t1 * t1 + t2 * t2 + t3 * t3))
    return np.array([
        [1.0 - 0.5 * (t2 * t2 + t3 * t3), 0.5 * t1 * t2 + t3 * w, 0.5 * t1 * t3 - t2 * w],
        [0.5 * t1 * t2 - t3 * w, 1.0 - 0.5 * (t1 * t1 + t3 * t3), 0.5 * t2 * t3 + t1 * w],
        [0.5 * t1 * t3 + t2 * w, 0.5 * t2 * t3 - t1 * w, 1.0 - 0.5 * (t1 * t1 + t2 * t2)]])


def blade_gauge_loads(built, integ, accelerations, gauges) -> dict:
    """The gauge channels of `gauges` {blade: gauge numbers} (module doc) at
    the output times of `integ`; accelerations: {free coordinate: qdd}."""
    model, eq = built.model, built.eq
    t_all = integ.t
    free = list(model.system.free)
    qdd_free = np.column_stack([accelerations[n] for n in free]) if free else np.zeros((len(t_all), 0))
    turbine = model.turbine
    gravity = np.array([0.0, 0.0, -turbine.gravity])
    blade = turbine.blade
    nodes_ed = int(turbine.blade_nodes)
    length = blade.length
    dr = length / nodes_ed
    sets = {b: PointSet.of_body(eq, f"blade{b}") for b in gauges}
    aero = built.effect("aero")
    aero = aero if aero is not None and hasattr(aero, "augmented") else None
    out = {f"Spn{i}{k}L{a}b{b}": np.empty(len(t_all)) for b, gs in gauges.items() for i in gs
           for k in "FM" for a in "xyz"}
    for k, t in enumerate(t_all):
        q_all, qd_all, qdd_presc = eq.full_state(integ.q[k], integ.qd[k], t)
        qdd_all = qdd_presc.copy()
        qdd_all[eq.free_idx] = qdd_free[k]
        # the effects' loads and the positions and axes first: the frames are
        # computed into buffers that the perturbed states below overwrite
        _, applied = built.loads(t, q_all, qd_all)
        frames = built.frames(q_all, qd_all)
        here = {}
        for b, ps in sets.items():
            pos = ps.kinematics(frames, q_all, qd_all)[0].copy()
            loads = applied.get(f"blade{b}")
            if aero is not None:       # the aerodynamic loads as OpenFAST maps them onto the nodes
                loads = aero.openfast_node_loads(b - 1, pos[:nodes_ed])
            here[b] = (pos, frames[0][eq.body_index[f"blade{b}"]].copy(), None if loads is None else np.array(loads))
        velocity = {}
        for sign in (1.0, -1.0):
            state = (q_all + sign * STEP * qd_all, qd_all + sign * STEP * qdd_all)
            frames = built.frames(*state)
            velocity[sign] = {b: ps.kinematics(frames, *state)[1].copy() for b, ps in sets.items()}
        for b, gs in gauges.items():
            ps = sets[b]
            pos, R, node_loads = here[b]
            acc = (velocity[1.0][b] - velocity[-1.0][b]) / (2.0 * STEP)
            mass = np.asarray(eq.system.body(f"blade{b}").node_mass, float)
            load = np.zeros((len(mass), 6))
            if node_loads is not None:
                load[:, :node_loads.shape[1]] = node_loads
            load[:, :3] += mass[:, None] * (gravity[None, :] - acc)
            j1, j2, j3 = R[:, 0], R[:, 1], R[:, 2]
            slopes = model.station_slopes(f"blade{b}", ps.s0[:nodes_ed, 2])
            qe = q_all[ps.idx]
            for i in gs:
                g = turbine.blade_gauges[i - 1] - 1
                outer = np.arange(g + 1, len(mass))          # the outboard nodes and the tip mass
                arm = pos[outer] - pos[g]
                force = load[outer, :3].sum(axis=0) + 0.5 * load[g, :3]
                moment = (np.cross(arm, load[outer, :3]).sum(axis=0) + load[outer, 3:].sum(axis=0)
                          + np.cross(0.25 * dr * j3, 0.5 * load[g, :3]) + 0.5 * load[g, 3:])
                twist = np.interp(ps.s0[g, 2], blade.span - blade.span[0], blade.twist)
                c, s = np.cos(twist), np.sin(twist)
                lj = np.array([c * j1 - s * j2, s * j1 + c * j2, j3])
                sx, sy = (slopes[g] @ qe)[:2] if len(qe) else (0.0, 0.0)
                theta_ip, theta_oop = -sy, sx
                axes = small_rotation(c * theta_ip - s * theta_oop, s * theta_ip + c * theta_oop) @ lj
                for a, n in zip("xyz", axes):
                    out[f"Spn{i}FL{a}b{b}"][k] = force @ n / 1e3
                    out[f"Spn{i}ML{a}b{b}"][k] = moment @ n / 1e3
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


def tower_gauge_loads(built, integ, accelerations, gauges, yaw_bearing) -> dict:
    """TwHt<i>[FM]L[xyz]t of gauges `gauges` (module doc) at the output times
    of `integ`; accelerations: {free coordinate: qdd}; yaw_bearing: the
    YAW_BEARING_LOADS histories [kN, kN m]."""
    model, eq = built.model, built.eq
    turbine = model.turbine
    t_all = integ.t
    free = list(model.system.free)
    qdd_free = np.column_stack([accelerations[n] for n in free]) if free else np.zeros((len(t_all), 0))
    gravity = np.array([0.0, 0.0, -turbine.gravity])
    nodes_ed = int(turbine.tower_nodes)
    dh = turbine.tower.length / nodes_ed
    ps = PointSet.of_body(eq, "tower")
    body = eq.system.body("tower")
    mass = np.asarray(body.node_mass, float)[:nodes_ed]
    yb = eq.body_index["yaw_bearing"]
    base = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])     # a1, a2, a3
    fa = [d for d in model.field_dofs.get("tower_fa", ())]
    ss = [d for d in model.field_dofs.get("tower_ss", ())]
    x_nodes = ps.s0[:nodes_ed, 2] / turbine.tower.length
    slope_fa = model.shapes["tower_fa"](x_nodes).dphi / turbine.tower.length if fa else None
    slope_ss = model.shapes["tower_ss"](x_nodes).dphi / turbine.tower.length if ss else None
    out = {f"TwHt{i}{k}L{a}t": np.empty(len(t_all)) for i in gauges for k in "FM" for a in "xyz"}
    for k, t in enumerate(t_all):
        q_all, qd_all, qdd_presc = eq.full_state(integ.q[k], integ.qd[k], t)
        qdd_all = qdd_presc.copy()
        qdd_all[eq.free_idx] = qdd_free[k]
        _, applied = built.loads(t, q_all, qd_all)
        loads_applied = applied.get("tower")
        loads_applied = None if loads_applied is None else np.array(loads_applied)[:nodes_ed]
        frames = built.frames(q_all, qd_all)
        pos = ps.kinematics(frames, q_all, qd_all)[0][:nodes_ed].copy()
        R_p, r_top = frames[0][yb].copy(), frames[1][yb][0].copy()
        velocity, top = {}, {}
        for sign in (1.0, -1.0):
            state = (q_all + sign * STEP * qd_all, qd_all + sign * STEP * qdd_all)
            frames = built.frames(*state)
            velocity[sign] = ps.kinematics(frames, *state)[1][:nodes_ed].copy()
            top[sign] = frames[1][yb][1].copy()
        acc = (velocity[1.0] - velocity[-1.0]) / (2.0 * STEP)
        acc_top = (top[1.0] - top[-1.0]) / (2.0 * STEP)
        load = np.zeros((nodes_ed, 6))
        if loads_applied is not None:
            load[:, :loads_applied.shape[1]] = loads_applied
        load[:, :3] += mass[:, None] * (gravity[None, :] - acc)
        f_top = R_p @ np.array([yaw_bearing[n][k] for n in YAW_BEARING_LOADS[:3]]) * 1e3
        m_top = R_p @ np.array([yaw_bearing[n][k] for n in YAW_BEARING_LOADS[3:]]) * 1e3
        f_top = f_top + turbine.yaw_bearing_mass * (gravity - acc_top)
        for i in gauges:
            g = turbine.tower_gauges[i - 1] - 1
            outer = np.arange(g + 1, nodes_ed)
            force = f_top + load[outer, :3].sum(axis=0) + 0.5 * load[g, :3]
            moment = (np.cross(r_top - pos[g], f_top) + m_top
                      + np.cross(pos[outer] - pos[g], load[outer, :3]).sum(axis=0) + load[outer, 3:].sum(axis=0)
                      + np.cross(0.25 * dh * base[1], 0.5 * load[g, :3]) + 0.5 * load[g, 3:])
            theta_fa = -float(slope_fa[:, g] @ q_all[[eq.index[d] for d in fa]]) if fa else 0.0
            theta_ss = float(slope_ss[:, g] @ q_all[[eq.index[d] for d in ss]]) if ss else 0.0
            t1, t2, t3 = small_rotation(theta_ss, 0.0, theta_fa) @ base
            for a, n, sign in (("x", t1, 1.0), ("y", t3, -1.0), ("z", t2, 1.0)):
                out[f"TwHt{i}FL{a}t"][k] = sign * (force @ n) / 1e3
                out[f"TwHt{i}ML{a}t"][k] = sign * (moment @ n) / 1e3
    return out
