"""OpenFAST-named output channels from the integrated coordinates.

Channels (units as OpenFAST writes them): Time [s]; Q_<dof> [m or rad] and
QD_<dof> for every free coordinate; Azimuth [deg, 0-360) of blade 1;
RotSpeed [rpm]; GenSpeed [rpm]; TTDspFA, TTDspSS [m] tower-top
displacement (SS positive along +y); TTDspTwst [deg]; OoPDefl<b>, IPDefl<b>
[m] blade-tip out-of-plane / in-plane deflection; PtfmSurge [m];
PtfmPitch [deg]; NacYaw [deg].
"""
from __future__ import annotations

import numpy as np
import pandas as pd


def channels(model, eq, integ, presc_fn=None) -> pd.DataFrame:
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
    for b in range(1, model.turbine.num_blades + 1):
        flap = [dofs for dofs in model.field_dofs.get("blade_flap", []) if dofs and dofs[0].startswith(f"B{b}")]
        edge = [dofs for dofs in model.field_dofs.get("blade_edge", []) if dofs and dofs[0].startswith(f"B{b}")]
        if flap or edge:
            data[f"OoPDefl{b}"] = sum((coord(d)[0] for ds in flap for d in ds), np.zeros_like(t))
            data[f"IPDefl{b}"] = sum((coord(d)[0] for ds in edge for d in ds), np.zeros_like(t))
    if "PtfmSurge" in idx or "PtfmSurge" in model.system.fixed:
        data["PtfmSurge"] = coord("PtfmSurge")[0]
    if "PtfmPitch" in idx or "PtfmPitch" in model.system.fixed:
        data["PtfmPitch"] = np.rad2deg(coord("PtfmPitch")[0])
    if "Yaw" in idx or "Yaw" in model.system.fixed:
        data["NacYaw"] = np.rad2deg(coord("Yaw")[0])
    return pd.DataFrame(data)
