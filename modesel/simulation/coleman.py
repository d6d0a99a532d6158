"""Multi-blade coordinates (Coleman transform; Bir 2008, NREL/CP-500-42553)
of a three-bladed rotor, for modes seen from the fixed frame.

Each blade DOF type X (F1, E1, ...) becomes X_coll, X_cos, X_sin with
blade b's coordinate q_b = X_coll + cos(psi_b) X_cos + sin(psi_b) X_sin,
psi_b = psi + 2 pi (b - 1) / 3. The equations in these
coordinates are averaged over MBC_AZIMUTHS rotor azimuths (one when the
rotor is parked). A cyclic mode of a turning rotor whirls: its pattern of
blade deflections turns with the rotor (forward) or against it (backward)
at the mode's frequency in the fixed frame, f_rotating +- Omega / 2 pi.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from modesel.errors import ModeselError
from modesel.multibody.linearize import LinearModel, linearize, state_modes
from modesel.vocabulary import (MULTIBLADE_PARTS, ROTOR_AZIMUTH, TOWER_FIELDS, blade_dof_type, multiblade_name,
                                parse_dof)

#: rotor azimuths over which the multi-blade linearisation is averaged
MBC_AZIMUTHS = 12
#: a mode is a cyclic (whirling) one when its X_cos and X_sin together hold
#: more than this share of its participation
CYCLIC_SHARE = 0.5


def blade_groups(names, num_blades: int) -> dict | None:
    """{blade DOF type: [index of blade 1, 2, 3 in `names`]} when the multi-blade
    transform applies (three blades on a flexible support: tower, yaw or
    platform DOFs), else None."""
    if num_blades != 3:
        return None
    support = False
    groups = {}
    for i, n in enumerate(names):
        d = parse_dof(n)
        if d.kind == "elastic" and d.blade is not None:
            groups.setdefault(blade_dof_type(n), [None] * 3)[d.blade - 1] = i
        elif (d.kind == "elastic" and d.field in TOWER_FIELDS) or (d.kind == "rigid" and n != ROTOR_AZIMUTH):
            support = True
    return groups if support and groups else None


def mbc_matrices(n: int, groups: dict, psi: float):
    """q_rot = T1 q_mbc and its first/second azimuth derivatives T2, T3
    with respect to psi, at rotor azimuth psi [rad]."""
    T1 = np.eye(n)
    T2 = np.zeros((n, n))
    T3 = np.zeros((n, n))
    for idx in groups.values():
        c0, cc, cs = idx
        for b, i in enumerate(idx):
            pb = psi + 2.0 * np.pi * b / 3.0
            c, s = np.cos(pb), np.sin(pb)
            T1[i, :] = 0.0
            T1[i, c0], T1[i, cc], T1[i, cs] = 1.0, c, s
            T2[i, cc], T2[i, cs] = -s, c
            T3[i, cc], T3[i, cs] = -c, -s
    return T1, T2, T3


def multiblade(built, groups: dict, qd0: np.ndarray, omega: float) -> LinearModel:
    """Linear model of `built` in multi-blade coordinates at rotor speed
    omega [rad/s] (q_rot = T1 q_mbc, psi = omega t), averaged over azimuths:
    M_B = T1^-1 M T1, C_B = T1^-1 (2 Omega M T2 + C T1),
    K_B = T1^-1 (Omega^2 M T3 + Omega C T2 + K T1)."""
    sys = built.model.system
    names = list(sys.free)
    n = len(names)
    az0 = built.scene.initial.get("Azimuth", 0.0)
    prescribed = ROTOR_AZIMUTH in sys.prescribed
    free_azimuth = names.index(ROTOR_AZIMUTH) if ROTOR_AZIMUTH in sys.free else None
    count = MBC_AZIMUTHS if (omega != 0.0 and (prescribed or free_azimuth is not None)) else 1
    mbc_names = list(names)
    for key, idx in groups.items():
        for i, part in zip(idx, MULTIBLADE_PARTS):
            mbc_names[i] = multiblade_name(key, part)
    MB = np.zeros((n, n))
    CB = np.zeros((n, n))
    KB = np.zeros((n, n))
    rhs = built.rhs()       # compiled, as `modal.linearize_scene`
    for k in range(count):
        psi = az0 + 2.0 * np.pi * k / count
        q0 = np.zeros(n)
        t = 0.0
        if count > 1 and prescribed:
            t = (psi - az0) / omega
        elif count > 1:
            q0[free_azimuth] = psi
        lin = linearize(rhs, q0, qd0, names, t=t)
        T1, T2, T3 = mbc_matrices(n, groups, psi)
        Ti = np.linalg.inv(T1)
        MB += Ti @ lin.M @ T1
        CB += Ti @ (2.0 * omega * lin.M @ T2 + lin.C @ T1)
        KB += Ti @ (omega**2 * lin.M @ T3 + omega * lin.C @ T2 + lin.K @ T1)
    return LinearModel(mbc_names, MB / count, CB / count, KB / count)


def with_whirl(modes: list, names, omega: float) -> list:
    """`modes` of a multi-blade model, each cyclic one (X_cos + X_sin hold
    more than CYCLIC_SHARE of its participation) marked "forward" or
    "backward" whirl at rotor speed omega [rad/s] (none when parked). With
    X_cos = Re(a e^{i w t}) and X_sin = Re(c e^{i w t}), w > 0, the blade
    deflections are a wave cos(psi_b -+ w t) turning with the rotor when
    Im(conj(a) c) has the opposite sign to omega."""
    if omega == 0.0:
        return modes
    pos = {n: i for i, n in enumerate(names)}
    pairs = {}
    for n in names:
        d = parse_dof(n)
        if d.multiblade in ("cos", "sin"):
            pairs.setdefault(blade_dof_type(n), {})[d.multiblade] = pos[n]
    out = []
    for m in modes:
        whirl = None
        share, key = max(((m.participation[p["cos"]] + m.participation[p["sin"]], key)
                          for key, p in pairs.items()), default=(0.0, None))
        if share > CYCLIC_SHARE:
            a, c = m.shape[pairs[key]["cos"]], m.shape[pairs[key]["sin"]]
            whirl = "forward" if np.imag(np.conj(a) * c) * omega < 0 else "backward"
        out.append(replace(m, whirl=whirl) if whirl else m)
    return out


def openfast_modes(lins):
    """Modes of OpenFAST linearisations: `lins` is one `.lin` (parked rotor)
    or several at equally spaced azimuths of one revolution (turning rotor).

    Three-bladed rotors are transformed to multi-blade coordinates (MBC3,
    Bir 2008, NREL/CP-500-42553, eq. 14-20): blade DOF X of blade b =
    X_coll + cos(psi_b) X_cos + sin(psi_b) X_sin with psi_b = psi + 2 pi
    (b - 1) / 3; with x = T x_nr, T = [[T1, 0], [Omega T2, T1]], the
    non-rotating state matrix is A_nr = T^-1 (A T - dT/dt),
    dT/dt = [[Omega T2, 0], [Omega^2 T3, Omega T2]] (T2 = dT1/dpsi,
    T3 = d2T1/dpsi2), averaged over the azimuths. Its modes are found and
    labelled exactly as modesel's own (`multibody.linearize.state_modes`:
    modal participation, scale-free, so OpenFAST's A needs no mass matrix).
    A parked rotor (speed 0) uses the one azimuth of its file.
    Returns [(frequency_hz, damping_ratio, label)], labels as modesel's
    `linearize_scene` (F1_coll, E1_cos, TFA1, DrTr ...)."""
    from modesel.turbine.openfast_output import OpenFastLinearization
    lins = [lins] if isinstance(lins, OpenFastLinearization) else list(lins)
    first = lins[0]
    n = len(first.names)
    groups = blade_groups(first.names, 3)              # the same rule as modesel's own modes
    mbc = groups is not None and all(None not in g for g in groups.values())
    names = list(first.names)
    if mbc:
        for key, idx in groups.items():
            for i, part in zip(idx, MULTIBLADE_PARTS):
                names[i] = multiblade_name(key, part)
    A_nr = np.zeros((2 * n, 2 * n))
    for lin in lins:
        if lin.names != first.names:
            raise ModeselError("linearisation files with different states", file=lin.path)
        if not mbc:
            A_nr += lin.A
            continue
        om = lin.rotor_speed
        T1, T2, T3 = mbc_matrices(n, groups, lin.azimuth)
        Z = np.zeros((n, n))
        T = np.block([[T1, Z], [om * T2, T1]])
        Td = np.block([[om * T2, Z], [om**2 * T3, om * T2]])
        A_nr += np.linalg.solve(T, lin.A @ T - Td)
    A_nr /= len(lins)
    return [(m.frequency_hz, m.damping_ratio, m.label) for m in state_modes(A_nr, names)]
