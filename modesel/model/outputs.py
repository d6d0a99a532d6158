"""OpenFAST-named output channels from the integrated coordinates.

Channels (units as OpenFAST writes them):

- always: Time [s]; Q_<dof> [m or rad] and QD_<dof> for every free
  coordinate; Azimuth [deg, 0-360) of blade 1; RotSpeed [rpm]; GenSpeed
  [rpm]; TTDspFA, TTDspSS [m] tower-top displacement (SS positive along +y);
  TTDspTwst [deg]; OoPDefl<b>, IPDefl<b> [m] blade-tip out-of-plane /
  in-plane deflection along the coned frame's x/y axes (= TipDxc<b>,
  TipDyc<b>) and TipDxb<b>, TipDyb<b> along the pitched blade frame's
  (blades with DOFs; the tip displacement of every blade DOF, twisted
  shapes included, as ElastoDyn); PtfmSurge [m]; PtfmPitch [deg];
  NacYaw [deg] (when those DOFs exist).
- from effects (only when switched on): RotThrust [kN], RotTorq [kN m]
  (aero: aerodynamic rotor thrust along the shaft and torque about it, from
  the blade node forces); GenTq [kN m], GenPwr [kW] (generator torque law,
  power = torque * HSS speed * efficiency).
- reaction loads (when the model has reaction coordinates, model/template.py):
  TwrBsMyt [kN m] tower-base fore-aft (pitching) moment and RootMyc<b>
  [kN m] blade-root out-of-plane moment about the coned y_c axis.

Reaction loads: each is the generalised force of a rotation coordinate that
is fixed at 0 (about the ground y axis at the tower base; about the blade's
coned y_c axis at its root). With the full equations M qdd = F + R over all
coordinates, the constraint reaction of that row is R = M_row qdd - F_row,
and the moment the bodies beyond the joint exert on it (external + gravity
- inertial moments about the joint, i.e. sum over the bodies above of
r x (f_ext + m g - m a) plus their rotational inertia terms) is
-R = F_row - M_row qdd, with qdd the free accelerations of the solved
equations, the prescribed accelerations, and zero for fixed coordinates.
Positive TwrBsMyt bends the tower downwind, positive RootMyc bends the
blade downwind, as in OpenFAST.
"""
from __future__ import annotations

import re

import numpy as np
import pandas as pd

from modesel.model.effects.base import Effect
from modesel.vocabulary import dof_unit, parse_dof

#: units of the channels (OpenFAST's); <b> stands for a blade number. A
#: coordinate's Q_<dof> / QD_<dof> take its unit (vocabulary.dof_unit).
CHANNEL_UNITS = {
    "Time": "s", "Azimuth": "deg", "RotSpeed": "rpm", "GenSpeed": "rpm",
    "TTDspFA": "m", "TTDspSS": "m", "TTDspTwst": "deg", "OoPDefl<b>": "m", "IPDefl<b>": "m",
    "TipDxc<b>": "m", "TipDyc<b>": "m", "TipDxb<b>": "m", "TipDyb<b>": "m",
    "PtfmSurge": "m", "PtfmPitch": "deg", "NacYaw": "deg",
    "RotThrust": "kN", "RotTorq": "kN-m", "GenTq": "kN-m", "GenPwr": "kW",
    "TwrBsMyt": "kN-m", "RootMyc<b>": "kN-m",
}


def channel_unit(name: str) -> str | None:
    """Unit of a simulation output channel (OpenFAST's), None if unknown."""
    for prefix, rate in (("Q_", False), ("QD_", True)):
        if name.startswith(prefix):
            try:
                return dof_unit(name[len(prefix):], rate=rate)
            except ValueError:
                return None
    if name in CHANNEL_UNITS:
        return CHANNEL_UNITS[name]
    per_blade = re.fullmatch(r"(\D+)\d", name)
    return CHANNEL_UNITS.get(f"{per_blade.group(1)}<b>") if per_blade else None


def channels(built, integ) -> pd.DataFrame:
    """Channels of `built` (simulation.assembly.Built) along `integ` (integrate.Integration)."""
    model = built.model
    names = list(model.system.free)
    idx = {n: i for i, n in enumerate(names)}
    t = integ.t
    data = {"Time": t}
    for i, n in enumerate(names):
        data[f"Q_{n}"] = integ.q[:, i]
    for i, n in enumerate(names):
        data[f"QD_{n}"] = integ.qd[:, i]

    def coord(name):
        """Value and rate of any coordinate (free, prescribed or fixed)."""
        if name in idx:
            return integ.q[:, idx[name]], integ.qd[:, idx[name]]
        if name in model.system.prescribed:
            vals = np.array([model.system.prescribed[name](ti)[:2] for ti in t])
            return vals[:, 0], vals[:, 1]
        v = model.system.fixed.get(name, 0.0)
        return np.full_like(t, v), np.zeros_like(t)

    ge, ged = coord("GeAz")
    dt_, dtd = coord("DrTr")
    az = ge + dt_
    data["Azimuth"] = np.mod(np.rad2deg(az), 360.0)
    data["RotSpeed"] = (ged + dtd) * 30.0 / np.pi
    data["GenSpeed"] = ged * model.turbine.gearbox_ratio * 30.0 / np.pi
    fa = model.field_dofs.get("tower_fa", ())
    ss = model.field_dofs.get("tower_ss", ())
    tw = model.field_dofs.get("tower_torsion", ())
    data["TTDspFA"] = sum((coord(d)[0] for d in fa), np.zeros_like(t))
    data["TTDspSS"] = -sum((coord(d)[0] for d in ss), np.zeros_like(t))
    data["TTDspTwst"] = np.rad2deg(sum((coord(d)[0] for d in tw), np.zeros_like(t)))
    cp, sp = np.cos(model.pitch), np.sin(model.pitch)
    for b in range(1, model.turbine.num_blades + 1):
        dofs = [d for fld in ("blade_flap", "blade_edge") for ds in model.field_dofs.get(fld, [])
                if ds and parse_dof(ds[0]).blade == b for d in ds]
        if dofs:
            # tip deflection (ElastoDyn's rS0S at the tip: twisted shapes in the
            # pitched blade frame j) projected on the coned frame i:
            # OoPDefl = TipDxc, IPDefl = TipDyc; TipDxb, TipDyb along j1, j2
            tip_b = sum((coord(d)[0][:, None] * model.blade_tip_displacement(d)[None, :] for d in dofs),
                        np.zeros((len(t), 3)))
            data[f"OoPDefl{b}"] = tip_b[:, 0] * cp + tip_b[:, 1] * sp
            data[f"IPDefl{b}"] = -tip_b[:, 0] * sp + tip_b[:, 1] * cp
            data[f"TipDxc{b}"], data[f"TipDyc{b}"] = data[f"OoPDefl{b}"], data[f"IPDefl{b}"]
            data[f"TipDxb{b}"], data[f"TipDyb{b}"] = tip_b[:, 0], tip_b[:, 1]
    if "PtfmSurge" in idx or "PtfmSurge" in model.system.fixed:
        data["PtfmSurge"] = coord("PtfmSurge")[0]
    if "PtfmPitch" in idx or "PtfmPitch" in model.system.fixed:
        data["PtfmPitch"] = np.rad2deg(coord("PtfmPitch")[0])
    if "Yaw" in idx or "Yaw" in model.system.fixed:
        data["NacYaw"] = np.rad2deg(coord("Yaw")[0])
    data.update(load_channels(built, integ))
    return pd.DataFrame(data)


def load_channels(built, integ) -> dict:
    """Effect channels and reaction loads at every output time (empty when
    the scene has neither)."""
    with_channels = [e for e in built.acting if type(e).channels is not Effect.channels]
    reactions = built.model.reactions
    if not with_channels and not reactions:
        return {}
    eq = built.eq
    if not built.acting:
        # only compiled (linear) loads act: one compiled call for all output times
        names = list(reactions)
        loads = eq.compiled_rhs(built.linear, all_rows=True).reactions(
            integ.t, integ.q, integ.qd, [reactions[n] for n in names])
        return {n: loads[:, k] / 1e3 for k, n in enumerate(names)}
    rows = {name: eq.index[c] for name, c in reactions.items()}
    out = {}
    fi, pi = eq.free_idx, eq.presc_idx
    for k, ti in enumerate(integ.t):
        q, qd = integ.q[k], integ.qd[k]
        q_all, qd_all, qdd_p = eq.full_state(q, qd, ti)
        gen, nodes = built.loads(ti, q_all, qd_all)
        row = {}
        for e in with_channels:
            row.update(e.channels(built))
        if rows:
            M, F = eq.evaluate_full(q_all, qd_all, nodes or None, gen)
            qdd = np.zeros(eq.n_all)
            qdd[pi] = qdd_p[pi]
            rhs = F[fi] - M[np.ix_(fi, pi)] @ qdd_p[pi] if len(pi) else F[fi]
            qdd[fi] = np.linalg.solve(M[np.ix_(fi, fi)], rhs)
            for name, r in rows.items():
                row[name] = (F[r] - M[r] @ qdd) / 1e3
        for name, value in row.items():
            if name not in out:
                out[name] = np.full(len(integ.t), np.nan)
            out[name][k] = value
    return out
