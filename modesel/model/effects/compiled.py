"""The effects' loads inside the compiled integration loop.

`pack_loads(built, packed)` packs every switched-on effect that acts at
every right-hand side into two flat arrays (ints, floats) plus a state
array (scratch and latched switches), and `effect_loads` (compiled into a
numba cfunc of `kernel.LOADS_SIG` by `loads_function`, on first use, and
passed to the kernel as a first-class function, so
one compiled loop serves every scene with loads and stays in numba's
on-disk cache)
evaluates them by a dispatch on the effect kind. The physics are the same
compiled functions the Python path (`Built.M_F`, effects' `__call__`)
calls: `kinematics.points`, `aero.wind.wind_params`,
`effects.aero.station_rotations`/`inflow`/`distribute`/
`elastic_correction`/`node_moments`, `aero.bem.solve_elements`,
`aero.tower_drag.drag_forces`, `effects.generator.switched_torque`
and, for a scene with the tower influence (a variant of the cfunc,
`loads_function`, compiled on first use), `aero.wind.wind_velocity` and
`aero.tower_influence.tower_disturbance`; the
Python path stays the reference (tests/test_twins.py holds the two right-hand
sides equal).

Layout: ints[0] = number of records; each record starts with (kind, length
in ints) followed by its kind's ints, which hold offsets into floats and
state. state[0:N_PARAMS] is the wind at the current time (the wind record,
first, writes it); state[CHANNEL_FLAG] asks for the output channels, which
the records write into state slots (`Packer.channel`); a full field
(`aero.full_field`) lies in state from state[GRID_SLOT], its time slot
written by the wind record, so the wind's parameters are the whole state
(`aero.wind.wind_velocity`).
"""
from __future__ import annotations

import functools

import numpy as np
from numba import cfunc, njit

from modesel.aero.bem import bem_weight, solve_elements
from modesel.aero.tower_drag import drag_forces
from modesel.aero.tower_influence import tower_disturbance
from modesel.aero.wind import GRID_SLOT, N_PARAMS, wind_at, wind_params
from modesel.model.effects.aero import (distribute, elastic_correction, inflow, node_moments, point_loads,
                                        rotor_loads, rotor_power, station_rotations)
from modesel.model.effects.generator import LAW_PARAMETERS, switched_torque
from modesel.multibody.kernel import LOADS_SIG, view2, view3
from modesel.multibody.kinematics import points

from modesel.model.effects.packing import AERO, CHANNEL_FLAG, GENERATOR, TOWER_DRAG, WIND, Packer  # noqa: F401


def pack_loads(built, packed):
    """((effect_loads, ints, floats, state) for `CompiledRHS(loads=...)`,
    {output channel: (state slot, scale)} for its `channels`), or None when
    an acting effect has no compiled form (`compile_loads`).
    packed: the kernel's `packing.Packed` (its rows of the node loads:
    `node_start`, `load_points`)."""
    acting = built.acting
    if not acting:
        return None
    if not all(hasattr(e, "compile_loads") for e in acting):
        return None
    packer = Packer()
    wind = built.effect("wind")
    grid = 0                                 # state offset of a full field (none: 0)
    if wind is not None and hasattr(wind, "field"):
        w = wind.field
        if w.full_field is not None:         # the packed field in state, where wind_velocity finds it
            field = w.params(0.0)[GRID_SLOT + 1:]          # the packed field (header, data)
            grid = packer.scratch(len(field))
            packer.set_state(grid, field)
            packer.set_state(GRID_SLOT, [grid])
        packer.record(WIND, [packer.add(w.table), len(w.table), packer.add([w.reference_height,
                                                                           w.reference_length])])
        packer.set_state(N_PARAMS - 2, list(w.turn()))     # the field's turn (`aero.wind`); `wind_params` leaves it
    for e in acting:
        e.compile_loads(built, packer, packed)
    loads = loads_function(packer.tower_influence, grid > 0)
    return (loads,) + packer.arrays(), dict(packer.channels)


@njit(cache=True)
def _point_kinematics(ints, p, floats, R, vec, q_all, qd_all, pos, vel):
    """Positions and velocities of the point set whose ints start at p;
    returns the number of ints it used."""
    body, m, ne, off = ints[p], ints[p + 1], ints[p + 2], ints[p + 3]
    s0 = view2(floats, off, m, 3)
    off += 3 * m
    Phi = view3(floats, off, m, 3, ne)
    off += 3 * m * ne
    S = view3(floats, off, m, ne, ne)
    off += m * ne * ne
    axis = floats[off:off + 3]
    qe = np.empty(ne)
    qde = np.empty(ne)
    for l in range(ne):
        qe[l] = q_all[ints[p + 4 + l]]
        qde[l] = qd_all[ints[p + 4 + l]]
    points(R[body], vec[body], s0, Phi, S, axis, qe, qde, pos, vel)
    return 4 + ne


@njit(cache=True)
def _stations(ints, p, floats, state, R, vec, q_all, qd_all):
    """The blade stations' positions, velocities and section rotations (effects/aero.py
    `BladeAerodynamics.__call__`, step 1) into the aero record's scratch (`_aero`)."""
    B, M, o_scr, o_slopes = ints[p + 1], ints[p + 2], ints[p + 10], ints[p + 12]
    pos = view3(state, o_scr, B, M, 3)
    vel = view3(state, o_scr + B * M * 3, B, M, 3)
    rotation = view3(state, o_scr + 2 * B * M * 3, B, M, 3)
    blades = ints[p + 30:p + 30 + B]
    p += ints[p + 28]                 # the stations' point sets
    so = o_slopes
    for b in range(B):
        ne = ints[p + 2]
        qe = np.empty(ne)
        for l in range(ne):
            qe[l] = q_all[ints[p + 4 + l]]
        Gs = view3(floats, so, M, 3, ne)
        so += M * 3 * ne
        p += _point_kinematics(ints, p, floats, R, vec, q_all, qd_all, pos[b], vel[b])
        station_rotations(R[blades[b]], Gs, qe, rotation[b])


@njit(cache=True)
def _aero(ints, p, floats, state, R, vec, q_all, qd_all, fnodes, fflag, gen, held, field):
    """Blade BEM loads (effects/aero.py `BladeAerodynamics.__call__`, steps 2-5)
    at the stations `_stations` left in the record's scratch, with the tower's
    influence `_tower` left there (zeros without): inflow, BEM, distribution to the nodes
    and node moments, or the same loads at the blades' load points (`point_loads`),
    ElastoDyn's generalised-force correction when packed.
    The generalised forces are summed in a state slot (n_all) and added to
    gen; held != 0: only that, with the node forces left as they are (LOADS_SIG).
    field None: uniform wind (`aero.wind.wind_at`), else a full field may be packed."""
    hub, B, M, N, o_const, o_elem, o_T, o_pol, G, PG, o_scr = (ints[p], ints[p + 1], ints[p + 2], ints[p + 3],
                                                                ints[p + 4], ints[p + 5], ints[p + 6],
                                                                ints[p + 7], ints[p + 8], ints[p + 9],
                                                                ints[p + 10])
    o_ref, o_loss, static_loss, o_corr, ne_el = ints[p + 11], ints[p + 13], ints[p + 14], ints[p + 15], ints[p + 16]
    has_corr, o_mom, K, o_ch = ints[p + 17], ints[p + 18], ints[p + 19], ints[p + 20]
    WT, WL = ints[p + 21], ints[p + 22]          # band widths of the transfer and lumping rows
    kept = state[ints[p + 23]:ints[p + 23] + gen.shape[0]]      # the generalised forces of the last call
    rows, o_pts = ints[p + 24], ints[p + 25]          # rows per blade: nodes (N) or load points (M, o_pts > 0)
    dist = view3(state, ints[p + 26], B, M, 3)
    if held != 0:
        for i in range(gen.shape[0]):
            gen[i] += kept[i]
        return
    kept[:] = 0.0
    flags_at = p + ints[p + 29]       # the BEM flags, after the stations' point sets (`_stations`)
    p += 30
    blades = ints[p:p + B]
    starts = ints[p + B:p + 2 * B]
    offset = ints[p + 2 * B:p + 2 * B + B * M]
    p += 2 * B + B * M
    elastic = view2(ints, p, B, ne_el)
    p += B * ne_el
    near = ints[p:p + K]
    p += K
    T_first = ints[p:p + N]
    p += N
    L_first = ints[p:p + K]
    o = o_scr
    pos = view3(state, o, B, M, 3)
    o += B * M * 3
    vel = view3(state, o, B, M, 3)
    o += B * M * 3
    rotation = view3(state, o, B, M, 3)
    o += B * M * 3
    en = view3(state, o, B, M, 3)
    o += B * M * 3
    et = view3(state, o, B, M, 3)
    o += B * M * 3
    vn = view2(state, o, B, M)
    o += B * M
    vt = view2(state, o, B, M)
    o += B * M
    skew = view2(state, o, B, M)
    o += B * M
    psi = view2(state, o, B, M)
    o += B * M
    r_local = view2(state, o, B, M)
    o += B * M
    tip_ratio = view2(state, o, B, M)
    o += B * M
    section = view2(state, o, B, M)
    o += B * M
    c_tip = state[o:o + B * M]
    o += B * M
    c_hub = state[o:o + B * M]
    o += B * M
    vrel = state[o:o + 3]
    o += 3
    out = view2(state, o, 13, B * M)
    o += 13 * B * M
    forces = view3(state, o, B, rows, 6)
    o += B * rows * 6
    guess = state[o:o + B * M]
    A = view3(floats, o_ref, M, 3, 3)
    wp = state                     # the wind's parameters, and a full field's grid (module doc)
    tsr = inflow(R, vec, hub, blades, pos, vel, rotation, A, wp, dist, vn, vt, skew, psi, en, et, section,
                 r_local, tip_ratio, vrel, field)
    c = floats[o_const:o_const + 6]
    theta = section.ravel()
    chord = floats[o_elem:o_elem + B * M]
    r = r_local.ravel()
    if static_loss != 0:       # element loops: an array slice copy compiles numba's shape-error message (2 s)
        for i in range(B * M):
            c_tip[i] = floats[o_loss + i]
            c_hub[i] = floats[o_loss + B * M + i]
    else:                 # BemSolver.solve_into: constants from the radius of this solve
        for i in range(B * M):
            c_tip[i] = 0.5 * c[0] * (c[1] - r[i]) / r[i]
            c_hub[i] = 0.5 * c[0] * (r[i] - c[2]) / c[2]
    grid = floats[o_pol:o_pol + G]
    value = view2(floats, o_pol + G, 3, PG)
    slope = view2(floats, o_pol + G + 3 * PG, 3, PG)
    flags = ints[flags_at:flags_at + 7]
    solve_elements(r, vn.ravel(), vt.ravel(), theta, chord, offset, skew.ravel(), psi.ravel(),
                   tip_ratio.ravel(), c_tip, c_hub, grid, value, slope, c[0], c[3],
                   flags[0] != 0, flags[1] != 0, flags[2] != 0, flags[3] != 0, flags[4] != 0, flags[5] != 0,
                   c[4], c[5], flags[6], bem_weight(tsr), out, guess)
    fn = view2(out[9], 0, B, M)
    ft = view2(out[10], 0, B, M)
    if has_corr != 0:
        D = view3(floats, o_corr, M, 3, ne_el)
        elastic_correction(fn, ft, en, et, R, blades, D, elastic, kept)
    cm_scale = floats[o_mom]
    if o_pts > 0:
        w = floats[o_pts:o_pts + M]
        wm = floats[o_pts + M:o_pts + 2 * M]
        op = o_pts + 2 * M
        ow = view2(floats, op, M, 3)
        op += 3 * M
        Dc = view3(floats, op, M, ne_el, 3)
        op += 3 * M * ne_el
        Dg = view3(floats, op, M, ne_el, 3)
        point_loads(fn, ft, view2(out[11], 0, B, M), cm_scale, en, et, R, blades, w, wm, ow, Dc, Dg, elastic,
                    forces, kept)
    else:
        T = view2(floats, o_T, N, WT)
        distribute(fn, ft, en, et, T, T_first, forces)
        om = o_mom + 1
        L = view2(floats, om, K, WL)
        om += K * WL
        moff = view2(floats, om, K, 3)
        om += 3 * K
        nslopes = view3(floats, om, N, 3, ne_el)
        node_moments(fn, ft, view2(out[11], 0, B, M), cm_scale, en, et, R, blades, L, L_first, near, moff,
                     nslopes, elastic, forces, kept)
    for i in range(gen.shape[0]):
        gen[i] += kept[i]
    for b in range(B):
        s = starts[b]
        for i in range(rows):
            for k in range(6):
                fnodes[s + i, k] += forces[b, i, k]
        fflag[blades[b]] = 1
    if state[CHANNEL_FLAG] != 0.0:          # the node point sets follow the 7 flags
        r_max = r[0]
        for i in range(1, B * M):
            r_max = max(r_max, r[i])
        _rotor_channels(ints, flags_at + 7, floats, R, vec, q_all, qd_all, forces, hub, c[3], r_max, vrel, tsr,
                        skew[0, 0], state[o_ch:o_ch + 15])


@njit(cache=True)
def _tower(ints, p, floats, state, R, vec, q_all, qd_all, field):
    """The tower's influence on the wind at the blade stations (effects/aero.py
    `_disturb`, `aero.tower_influence.tower_disturbance`) of the aero record
    whose ints start at p, at the stations `_stations` left in its scratch,
    into its dist slot; the influence's ints (potential, shadow, m, props,
    scratch, tower points) start at the record's tower slot (none: nothing)."""
    if ints[p + 27] == 0:
        return
    B, M, o_scr = ints[p + 1], ints[p + 2], ints[p + 10]
    stations = view3(state, o_scr, B, M, 3)
    dist = view3(state, ints[p + 26], B, M, 3)
    p += ints[p + 27]
    potential, shadow, m, o_props, o_tw = ints[p], ints[p + 1], ints[p + 2], ints[p + 3], ints[p + 4]
    pos = view2(state, o_tw, m, 3)
    vel = view2(state, o_tw + 3 * m, m, 3)
    wind = view2(state, o_tw + 6 * m, m, 3)
    _point_kinematics(ints, p + 5, floats, R, vec, q_all, qd_all, pos, vel)
    wp = state
    for k in range(m):
        wind[k, 0], wind[k, 1], wind[k, 2] = wind_at(wp, pos[k, 0], pos[k, 1], pos[k, 2], field)
    tower_disturbance(potential, shadow, stations, pos, vel, wind, floats[o_props:o_props + 3 * m], dist)


@njit(cache=True)
def _rotor_channels(ints, p, floats, R, vec, q_all, qd_all, forces, hub, rho, rmax, vrel, tsr, chi0, out):
    """AeroDyn's rotor channels (effects/aero.py `BladeAerodynamics.channels`)
    of the node loads `forces` (B, N, 6) into out: RtAeroFxh [N], RtAeroMxh
    [N m], RtAeroPwr [W], RtAeroCp, RtAeroCq, RtAeroCt [-], RtSpeed [rpm],
    RtTSR [-] (tsr), RtVAvgxh [m/s], RtSkew [deg] (chi0 [rad]), RtArea
    [m^2], RtAeroFyh, RtAeroFzh [N], RtAeroMyh, RtAeroMzh [N m]; the node
    point sets' ints start at p."""
    B, N = forces.shape[0], forces.shape[1]
    pos = np.empty((N, 3))
    vel = np.empty((N, 3))
    loads = np.zeros(6)
    for b in range(B):
        p += _point_kinematics(ints, p, floats, R, vec, q_all, qd_all, pos, vel)
        rotor_loads(forces[b], pos, R[hub], vec[hub, 0], loads)
    thrust, torque = loads[0], loads[3]
    omega = 0.0
    v = 0.0
    for k in range(3):
        omega += vec[hub, 2, k] * R[hub, k, 0]
        v += vrel[k] * R[hub, k, 0]
    out[0] = thrust
    out[1] = torque
    out[2], out[3], out[4], out[5] = rotor_power(torque, thrust, omega, v, rho, rmax)
    out[6] = omega * 30.0 / np.pi
    out[7] = tsr
    out[8] = v
    out[9] = chi0 * 180.0 / np.pi
    out[10] = np.pi * rmax * rmax
    out[11], out[12], out[13], out[14] = loads[1], loads[2], loads[4], loads[5]


@njit(cache=True)
def _tower_drag(ints, p, floats, state, R, vec, q_all, qd_all, fnodes, fflag, field):
    """Tower drag (effects/tower_drag.py): the line load at the stations,
    carried to the tower's load rows by the transfer's bands (its nodes) or
    the points' weights (its load points); not called while the loads are
    held (LOADS_SIG), which keeps those of the last call."""
    start, rows, width, o_coef, o_scr, o_band = ints[p], ints[p + 1], ints[p + 2], ints[p + 3], ints[p + 4], ints[p + 5]
    first = ints[p + 6:p + 6 + rows]
    a = p + 6 + rows
    body, m = ints[a], ints[a + 1]
    pos = view2(state, o_scr, m, 3)
    vel = view2(state, o_scr + 3 * m, m, 3)
    line = view2(state, o_scr + 6 * m, m, 3)
    _point_kinematics(ints, a, floats, R, vec, q_all, qd_all, pos, vel)
    drag_forces(pos, vel, state, floats[o_coef:o_coef + m], line, field)
    band = view2(floats, o_band, rows, width)
    for i in range(rows):
        f0 = first[i]
        v0 = v1 = 0.0
        for k in range(width):
            w = band[i, k]
            v0 += w * line[f0 + k, 0]
            v1 += w * line[f0 + k, 1]
        fnodes[start + i, 0] += v0
        fnodes[start + i, 1] += v1
    fflag[body] = 1


@njit(cache=True)
def _generator(t, ints, p, floats, state, qd_all, gen):
    """Generator torque on GeAz (effects/generator.py)."""
    i, law, o_f, o_s = ints[p], ints[p + 1], ints[p + 2], ints[p + 3]
    ratio = floats[o_f]
    lp = floats[o_f + 1:o_f + 1 + LAW_PARAMETERS]
    sw = floats[o_f + 1 + LAW_PARAMETERS:o_f + 7 + LAW_PARAMETERS]
    latch = state[o_s:o_s + 2]
    T, P = switched_torque(t, ratio * qd_all[i], law, lp, sw, latch)
    gen[i] -= ratio * T
    state[o_s + 2] = T
    state[o_s + 3] = P


@njit(inline="always")
def _dispatch(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held, tower, field):
    """The loop over the records (`effect_loads`), inlined into each cfunc
    that calls it (no compiled level of its own); tower None: numba prunes the
    tower influence's branch, whose code then compiles only into the variants
    with it (`loads_function`); field None: likewise the full field's."""
    p = 1
    for _ in range(ints[0]):
        kind, length = ints[p], ints[p + 1]
        a = p + 2
        if kind == WIND:
            grid = int(state[GRID_SLOT])
            if grid > 0:
                state[grid] = t                   # the full field's time slot
            else:
                n = ints[a + 1]
                wind_params(view2(floats, ints[a], n, 9), floats[ints[a + 2]],
                            floats[ints[a + 2] + 1], t, state[0:N_PARAMS])
        elif kind == AERO:
            if held == 0:
                _stations(ints, a, floats, state, R, vec, q_all, qd_all)
                if tower is not None:
                    _tower(ints, a, floats, state, R, vec, q_all, qd_all, field)
            _aero(ints, a, floats, state, R, vec, q_all, qd_all, fnodes, fflag, gen, held, field)
        elif kind == TOWER_DRAG:
            if held == 0:
                _tower_drag(ints, a, floats, state, R, vec, q_all, qd_all, fnodes, fflag, field)
        else:
            _generator(t, ints, a, floats, state, qd_all, gen)
        p += length
    for i in range(gen.shape[0]):
        if not np.isfinite(gen[i]):
            return 4                                  # kernel.NON_FINITE_ACC
    return 0


def effect_loads(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held):
    """All packed effects' loads at time t (module doc; `kernel.LOADS_SIG`).
    held != 0: the BEM loads and the tower drag are those of the last call
    (their node forces stay in fnodes, the BEM's generalised forces are added
    again); the wind and the generator are evaluated (a generator law can be
    stiff: its torque's slope stays in Radau's Jacobian). Without the tower
    influence and the full field (`loads_function` has them)."""
    return _dispatch(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held, None, None)


def _loads_tower(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held):
    """`effect_loads` with the tower influence (`_tower`)."""
    return _dispatch(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held, True, None)


def _loads_field(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held):
    """`effect_loads` with a full field (`aero.full_field`)."""
    return _dispatch(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held, None, True)


def _loads_tower_field(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held):
    """`effect_loads` with the tower influence and a full field."""
    return _dispatch(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held, True, True)


_VARIANTS = {(False, False): effect_loads, (True, False): _loads_tower, (False, True): _loads_field,
             (True, True): _loads_tower_field}


@functools.lru_cache(maxsize=None)
def loads_function(tower: bool = False, field: bool = False):
    """The cfunc (`kernel.LOADS_SIG`) of the loads, with AeroDyn's tower
    influence on the blades' wind (`_tower`) and/or a full field's wind
    (`aero.full_field`) where asked, `effect_loads` without either: each
    compiled on its first call in a process (loaded from numba's cache
    after the first run), so that a scene's first run compiles the one
    variant it runs, and the influence's and the field's code stays out of
    the others."""
    return cfunc(LOADS_SIG, cache=True)(_VARIANTS[bool(tower), bool(field)])
