"""ServoDyn (OpenFAST `modules/servodyn/src/ServoDyn.f90`): the generator
torque laws and the reading of a ServoDyn input file.

Torque laws (HSS speed w [rad/s], torque on the HSS [N m]); units as
ServoDyn converts its inputs (rpm -> rad/s, N m/rpm^2 -> N m/(rad/s)^2,
percent -> fraction):

- simple variable-speed control, VSContrl = 1 (CalculateTorque,
  ControlMode_SIMPLE), with w_sync = VS_RtGnSp / (1 + VS_SlPc),
  slope = VS_RtTq / (VS_RtGnSp - w_sync) and the region 2 -> 2.5
  transition w_tr = (slope - sqrt(slope (slope - 4 k w_sync))) / (2 k):

      w >= VS_RtGnSp        T = VS_RtTq                     (region 3)
      w <  w_tr             T = k w^2, k = VS_Rgn2K         (region 2; no
                            cut-in: region 1 is k w^2 down to standstill)
      otherwise             T = slope (w - w_sync)          (region 2.5)

  (VS_SlPc ~ 0: w_tr = VS_RtGnSp; k = 0: w_tr = w_sync.) Electrical power
  P = T w GenEff. ServoDyn refuses negative w (motoring) in this mode.
- simple induction generator, VSContrl = 0 with GenModel = 1: slip
  s = w - SIG_SySp, rated speed SIG_SySp (1 + SIG_SlPc), pull-out slip
  s_po = SIG_PORt (rated speed - SIG_SySp), slope SIG_RtTq / (rated speed -
  SIG_SySp): T = slope s for |s| <= s_po, else sign(s) SIG_RtTq SIG_PORt.
  P = T w GenEff when T >= 0 (generating), T w / GenEff when motoring.
- Thevenin-equivalent induction generator, VSContrl = 0 with GenModel = 2
  (ServoDyn's SrvD_Init constants and CalculateTorque): from the stator
  and rotor resistances R_s = TEC_SRes, R_r = TEC_RRes [ohm], leakage
  reactances X_s = TEC_SLR, X_r = TEC_RLR and magnetising reactance
  X_m = TEC_MR [ohm], line-to-line voltage V = TEC_VLL [V], line frequency
  f = TEC_Freq [Hz] and pole count p = TEC_NPol, with D = R_s^2 + (X_s + X_m)^2:
  R_e = R_s X_m^2 / D, X_e = X_m (R_s^2 + X_s (X_s + X_m)) / D,
  V_1 = X_m V / sqrt(3 D), w_sync = 4 pi f / p, and the slip ratio
  s = (w - w_sync) / w_sync,

      T = A s / (C0 + C1 s + C2 s^2),   A = R_r X_m^2 V^2 / (D w_sync),
      C0 = R_r^2,  C1 = -2 R_e R_r,  C2 = R_e^2 + (X_e + X_r)^2;

  the rotor current I_2 = V_1 s (s R_e - R_r - j s (X_e + X_r)) / D_2,
  D_2 = (s R_e - R_r)^2 + s^2 (X_e + X_r)^2, the stator current
  I_1 = I_2 - j V_1 / X_m, and P = T w - 3 |I_1|^2 R_s - 3 |I_2|^2 R_r
  (GenEff is not used).

On/off (Torque_UpdateStates): the generator is on line from TimGenOn
(GenTiStr = True) or from the first time w >= SpdGenOn (False); it goes
off for good at TimGenOf (GenTiStp = True) or when P <= 0 (False). Off
line, T = P = 0.

Pitch: with PCMode = 0 ServoDyn commands BlPitchCom = PitNeut from the
first step (Pitch_CalcOutput), whatever ElastoDyn's initial BlPitch; with
PitchDOF off ElastoDyn takes that command, so the pitch is PitNeut.
"""
from __future__ import annotations

import math

import numpy as np

from modesel.turbine.openfast_inputs import InputFile

RPM = math.pi / 30.0     # rad/s per rpm


def simple_vs_constants(rated_speed, rated_torque, k2, slip):
    """(w_sync, slope, w_transition) of the simple variable-speed law (SI)."""
    w_sync = rated_speed / (1.0 + slip)
    if slip < math.sqrt(np.finfo(float).eps):
        return w_sync, 9999.9, rated_speed
    slope = rated_torque / (rated_speed - w_sync)
    if abs(k2) < np.finfo(float).eps:
        return w_sync, slope, w_sync
    return w_sync, slope, (slope - math.sqrt(slope * (slope - 4.0 * k2 * w_sync))) / (2.0 * k2)


def simple_vs_torque(w, rated_speed, rated_torque, k2, w_sync, slope, w_tr):
    """ServoDyn's simple variable-speed torque [N m] at HSS speed w [rad/s]."""
    if w >= rated_speed:
        return rated_torque
    if w < w_tr:
        return k2 * w * w
    return slope * (w - w_sync)


def induction_torque(w, sync_speed, slope, pullout_slip, pullout_torque):
    """ServoDyn's simple induction generator torque [N m] at HSS speed w [rad/s]."""
    s = w - sync_speed
    if abs(s) > pullout_slip:
        return math.copysign(pullout_torque, s)
    return s * slope


def thevenin_constants(frequency, poles, r_stator, r_rotor, voltage, x_stator, x_rotor, x_magnetizing):
    """The 11 constants of `thevenin_torque_power` (module doc; SI units):
    (w_sync, A, C0, C1, C2, R_e, X_e + X_r, V_1, R_r, R_s, X_m)."""
    d = r_stator**2 + (x_stator + x_magnetizing)**2
    r_e = r_stator * x_magnetizing**2 / d
    x_e = x_magnetizing * (r_stator**2 + x_stator * (x_stator + x_magnetizing)) / d
    v_1 = x_magnetizing * voltage / math.sqrt(3.0 * d)
    w_sync = 4.0 * math.pi * frequency / poles
    a = r_rotor * x_magnetizing**2 / d / w_sync * voltage**2
    return (w_sync, a, r_rotor**2, -2.0 * r_e * r_rotor, r_e**2 + (x_e + x_rotor)**2, r_e, x_e + x_rotor, v_1,
            r_rotor, r_stator, x_magnetizing)


def thevenin_torque_power(w, w_sync, a, c0, c1, c2, r_e, x, v_1, r_rotor, r_stator, x_magnetizing):
    """ServoDyn's Thevenin-equivalent induction generator (module doc): torque
    [N m] and electrical power [W] at HSS speed w [rad/s]."""
    s = (w - w_sync) / w_sync
    torque = a * s / (c0 + c1 * s + c2 * s * s)
    d = (s * r_e - r_rotor)**2 + (s * x)**2
    i2_re = v_1 * s * (s * r_e - r_rotor) / d
    i2_im = -v_1 * s * s * x / d
    i1_im = i2_im - v_1 / x_magnetizing
    loss = 3.0 * (i2_re**2 + i1_im**2) * r_stator + 3.0 * (i2_re**2 + i2_im**2) * r_rotor
    return torque, torque * w - loss


def electrical_power(torque, w, efficiency):
    """CalculateElecPwr: efficiency subtracts when generating, adds when motoring."""
    return torque * w * efficiency if torque >= 0.0 else torque * w / efficiency


def read_servodyn(path, tmax: float, yaw_dof: bool = False) -> dict:
    """{"generator": options of the `generator` effect or None, "yaw": options of
    the `yaw` effect (with ElastoDyn's YawDOF on) or None, "pitch_deg":
    [PitNeut per blade]} of a ServoDyn file; inputs modesel does not model
    (pitch control or manoeuvres, DLL/Simulink/user control, brakes, yaw
    control, flaps, structural or cable control) raise a ModeselError
    naming the file and the input."""
    f = InputFile(path, "ServoDyn")
    if f.integer("PCMode") != 0:
        raise f.unsupported("PCMode", "pitch control")
    pit_neut, k = [], 1
    while f"PitNeut({k})" in f:
        pit_neut.append(f.number(f"PitNeut({k})"))
        k += 1
    if not pit_neut:
        raise f.error("input missing from the ServoDyn file", "PitNeut(1)")
    k = 1
    while f"TPitManS({k})" in f:
        if f.number(f"TPitManS({k})") < tmax:
            raise f.unsupported(f"TPitManS({k})", "override pitch manoeuvre within TMax")
        k += 1
    for label, what in (("HSSBrMode", "HSS brake"), ("YCMode", "yaw control"),
                        ("AfCmode", "airfoil flow control"), ("CCmode", "cable control"),
                        ("NumBStC", "blade structural control"), ("NumNStC", "nacelle structural control"),
                        ("NumTStC", "tower structural control"), ("NumSStC", "substructure structural control")):
        if label in f and f.integer(label) != 0:
            raise f.unsupported(label, what)
    yaw = None
    if yaw_dof:     # YCMode 0 (checked above): the spring and damper about YawNeut (`effects.yaw`)
        if "TYawManS" in f and f.number("TYawManS") < tmax:
            raise f.unsupported("TYawManS", "override yaw manoeuvre within TMax")
        yaw = {"stiffness": f.number("YawSpr"), "damping": f.number("YawDamp"), "neutral_deg": f.number("YawNeut")}
        for label, key in (("YawSpr", "stiffness"), ("YawDamp", "damping")):
            if yaw[key] < 0:
                raise f.error(f"must not be negative, got {yaw[key]:g}", label)
    vs = f.integer("VSContrl")
    eff = f.number("GenEff") / 100.0
    if not 0.0 < eff <= 1.0:
        raise f.error(f"GenEff must be in (0, 100] %, got {eff * 100:g}", "GenEff")
    timed_on, timed_off = f.flag("GenTiStr"), f.flag("GenTiStp")
    switching = {"efficiency": eff,
                 "on_time": f.number("TimGenOn") if timed_on else None,
                 "on_speed_rpm": None if timed_on else f.number("SpdGenOn"),
                 "off_time": f.number("TimGenOf") if timed_off else None,
                 "off_when_no_power": not timed_off}
    if vs == 1:
        gen = {"mode": "simple_variable_speed", "rated_speed_rpm": f.number("VS_RtGnSp"),
               "rated_torque": f.number("VS_RtTq"), "region2_k": f.number("VS_Rgn2K"),
               "slip_percent": f.number("VS_SlPc")}
        if gen["region2_k"] < 0:
            raise f.error("VS_Rgn2K must not be negative", "VS_Rgn2K")
        if gen["region2_k"] * gen["rated_speed_rpm"]**2 > gen["rated_torque"]:
            raise f.error("VS_Rgn2K*VS_RtGnSp^2 must not be greater than VS_RtTq", "VS_Rgn2K")
    elif vs == 0:
        model = f.integer("GenModel")
        if model not in (1, 2):
            raise f.unsupported("GenModel", "only the simple (1) and Thevenin-equivalent (2) induction generators "
                                            "are modelled")
        gen = _thevenin(f) if model == 2 else _induction(f)
    else:
        raise f.unsupported("VSContrl", "only 0 (generator model) and 1 (simple variable speed) are modelled")
    gen.update(switching)
    return {"generator": gen, "pitch_deg": pit_neut, "yaw": yaw}


#: the Thevenin generator's ServoDyn inputs and the `generator` effect's options, in the order of
#: `thevenin_constants`' arguments
THEVENIN_INPUTS = {"TEC_Freq": "line_frequency_hz", "TEC_NPol": "poles", "TEC_SRes": "stator_resistance",
                   "TEC_RRes": "rotor_resistance", "TEC_VLL": "line_voltage", "TEC_SLR": "stator_reactance",
                   "TEC_RLR": "rotor_reactance", "TEC_MR": "magnetizing_reactance"}


def _induction(f) -> dict:
    """The `generator` effect's options of a simple induction generator
    (GenModel = 1), checked as ServoDyn checks them."""
    gen = {"mode": "induction", "sync_speed_rpm": f.number("SIG_SySp"),
           "rated_torque": f.number("SIG_RtTq"), "slip_percent": f.number("SIG_SlPc"),
           "pullout_ratio": f.number("SIG_PORt")}
    for label, key in (("SIG_SlPc", "slip_percent"), ("SIG_SySp", "sync_speed_rpm"),
                       ("SIG_RtTq", "rated_torque")):
        if gen[key] <= 0:
            raise f.error(f"must be greater than zero, got {gen[key]:g}", label)
    if gen["pullout_ratio"] < 1:
        raise f.error(f"must not be less than 1, got {gen['pullout_ratio']:g}", "SIG_PORt")
    return gen


def _thevenin(f) -> dict:
    """The `generator` effect's options of a Thevenin generator (GenModel = 2),
    checked as ServoDyn checks them (SrvD ValidatePrimaryData)."""
    gen = {"mode": "thevenin"}
    for label, key in THEVENIN_INPUTS.items():
        value = f.integer(label) if label == "TEC_NPol" else f.number(label)
        if value <= 0 or (label == "TEC_NPol" and value % 2):
            raise f.error(f"must be {'an even number ' if label == 'TEC_NPol' else ''}greater than zero, got "
                          f"{value:g}", label)
        gen[key] = value
    return gen
