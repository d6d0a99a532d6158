"""Generator torque on the high-speed shaft.

    [effects.generator]
    mode = "variable_speed"     # | "constant" | "locked" | "simple_variable_speed" | "induction" | "thevenin"
    torque = 43093.55           # N m on the HSS (mode "constant")
    efficiency = 0.944          # electrical efficiency for GenPwr

ServoDyn's laws (`modesel.turbine.servodyn`, which documents them):

    mode = "simple_variable_speed"   # VSContrl = 1
    rated_speed_rpm = 1161.963       # VS_RtGnSp (HSS)
    rated_torque = 43093.55          # VS_RtTq [N m]
    region2_k = 0.0255764            # VS_Rgn2K [N m/rpm^2]
    slip_percent = 10.0              # VS_SlPc

    mode = "induction"               # VSContrl = 0, GenModel = 1
    sync_speed_rpm = 1200.0          # SIG_SySp
    rated_torque = 40000.0           # SIG_RtTq [N m]
    slip_percent = 1.0               # SIG_SlPc
    pullout_ratio = 2.0              # SIG_PORt

    mode = "thevenin"                # VSContrl = 0, GenModel = 2 (here the AOC 15/50's,
    line_frequency_hz = 60.0         # TEC_Freq                      OpenFAST r-test AOC_WSt)
    poles = 4                        # TEC_NPol
    stator_resistance = 0.0492       # TEC_SRes [ohm]
    rotor_resistance = 0.000534      # TEC_RRes [ohm]
    line_voltage = 480.0             # TEC_VLL [V]
    stator_reactance = 0.0001        # TEC_SLR [ohm]
    rotor_reactance = 0.0001         # TEC_RLR [ohm]
    magnetizing_reactance = 0.00449  # TEC_MR [ohm]

and, for these three modes, ServoDyn's switching: `on_time` (TimGenOn, s;
default 0) or `on_speed_rpm` (SpdGenOn, HSS), `off_time` (TimGenOf, s),
`off_when_no_power` (GenTiStp = False: off for good once the electrical
power is <= 0). Their power is ServoDyn's (efficiency subtracts when
generating, adds when motoring; the Thevenin generator's, its circuit's
losses, without `efficiency`). The speed and power switches latch at the
first right-hand side that meets them (an integrator stage that is later
rejected can latch them a step early).

The torque T [N m] acts on the generator, whose angle is N_g GeAz, so its
generalised force on GeAz is -N_g T. "locked": the generator does not turn
(GeAz fixed at the initial azimuth; no torque law). "constant": T as given.
"variable_speed": the NREL 5-MW baseline torque law (Jonkman et al. 2009,
NREL/TP-500-38060, section 7.1 and the DISCON source of its Appendix), of
the HSS speed w [rad/s]:

    region 1    w <= 70.16224                  T = 0
    region 1.5  70.16224 < w < 91.21091        linear from 0 to k w^2
    region 2    up to the 2.5 transition       T = k w^2,  k = 2.332287 N m/(rad/s)^2
    region 2.5  up to rated torque             T = s25 (w - w_sync), 10 % slip induction line
                                               through rated power 5296610 W at 121.6805 rad/s
    region 3    beyond                         T = 43093.55 N m (rated torque)

k = 2.332287 N m/(rad/s)^2 is Jonkman's 0.0255764 N m/rpm^2 (the task's
"N m/rpm^2" unit for 2.332287 is corrected here). Region 3 holds the rated
torque 43093.55 N m (= 5296610 W / 122.9096 rad/s) constant: the baseline
controller holds constant power with its pitch loop, but with the pitch
prescribed constant a constant-power torque (falling with speed) would
remove the speed's stability, while a constant torque keeps the equilibrium
stable where the aerodynamic torque falls with speed. Power:
GenPwr = T w efficiency (94.4 %, Jonkman 2009 Table 1-1).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from modesel.model.effects.base import Effect, Option
from modesel.turbine import servodyn as _sd

CUT_IN = 70.16224            # rad/s, VS_CtInSp (670 rpm)
REGION2_START = 91.21091     # rad/s, VS_Rgn2Sp (871 rpm)
K_REGION2 = 2.332287         # N m/(rad/s)^2, VS_Rgn2K
RATED_SPEED = 121.6805       # rad/s, VS_RtGnSp
RATED_POWER = 5296610.0      # W, VS_RtPwr (mechanical)
SLIP = 0.10                  # VS_SlPc
RATED_TORQUE = 43093.55      # N m on the HSS
EFFICIENCY = 0.944

SYNC_SPEED = RATED_SPEED / (1.0 + SLIP)
SLOPE15 = K_REGION2 * REGION2_START**2 / (REGION2_START - CUT_IN)
SLOPE25 = (RATED_POWER / RATED_SPEED) / (RATED_SPEED - SYNC_SPEED)
TRANSITION = (SLOPE25 - np.sqrt(SLOPE25 * (SLOPE25 - 4.0 * K_REGION2 * SYNC_SPEED))) / (2.0 * K_REGION2)


def variable_speed_torque(w: float) -> float:
    """NREL 5-MW generator torque [N m] at HSS speed w [rad/s] (module doc)."""
    if w <= CUT_IN:
        return 0.0
    if w < REGION2_START:
        torque = SLOPE15 * (w - CUT_IN)
    elif w < TRANSITION:
        torque = K_REGION2 * w * w
    else:
        torque = SLOPE25 * (w - SYNC_SPEED)
    return min(torque, RATED_TORQUE)


class Generator(Effect):
    name = "generator"
    CHANNELS = ("GenTq", "GenPwr")
    OPTIONS = {
        "mode": Option("choice", "variable_speed", "torque law",
                       choices=("variable_speed", "constant", "locked", "simple_variable_speed", "induction",
                                "thevenin")),
        "torque": Option("number", None, "constant HSS torque [N m]"),
        "efficiency": Option("number", EFFICIENCY, "generator efficiency [-]", positive=True),
        "rated_speed_rpm": Option("number", None, "VS_RtGnSp [rpm]", positive=True),
        "rated_torque": Option("number", None, "VS_RtTq / SIG_RtTq [N m]", positive=True),
        "region2_k": Option("number", None, "VS_Rgn2K [N m/rpm^2]", nonnegative=True),
        "slip_percent": Option("number", None, "VS_SlPc / SIG_SlPc [%]", nonnegative=True),
        "sync_speed_rpm": Option("number", None, "SIG_SySp [rpm]", positive=True),
        "pullout_ratio": Option("number", None, "SIG_PORt [-]", positive=True),
        "line_frequency_hz": Option("number", None, "TEC_Freq [Hz]", positive=True),
        "poles": Option("number", None, "TEC_NPol [-] (even)", positive=True),
        "stator_resistance": Option("number", None, "TEC_SRes [ohm]", positive=True),
        "rotor_resistance": Option("number", None, "TEC_RRes [ohm]", positive=True),
        "line_voltage": Option("number", None, "TEC_VLL [V]", positive=True),
        "stator_reactance": Option("number", None, "TEC_SLR [ohm]", positive=True),
        "rotor_reactance": Option("number", None, "TEC_RLR [ohm]", positive=True),
        "magnetizing_reactance": Option("number", None, "TEC_MR [ohm]", positive=True),
        "on_time": Option("number", None, "TimGenOn [s]", nonnegative=True),
        "on_speed_rpm": Option("number", None, "SpdGenOn [rpm] (HSS)"),
        "off_time": Option("number", None, "TimGenOf [s]", nonnegative=True),
        "off_when_no_power": Option("bool", False, "GenTiStp = False"),
    }
    SERVODYN = {"simple_variable_speed": ("rated_speed_rpm", "rated_torque", "region2_k", "slip_percent"),
                "induction": ("sync_speed_rpm", "rated_torque", "slip_percent", "pullout_ratio"),
                "thevenin": tuple(_sd.THEVENIN_INPUTS.values())}
    SWITCHING = ("on_time", "on_speed_rpm", "off_time", "off_when_no_power")

    def __init__(self, scene, options):
        super().__init__(scene, options)
        mode = options["mode"]
        if (mode == "constant") != (options["torque"] is not None):
            raise self.error("give torque exactly when mode = \"constant\"", "torque")
        self.loads = mode != "locked"
        needed = self.SERVODYN.get(mode, ())
        for key in set(k for keys in self.SERVODYN.values() for k in keys) | set(self.SWITCHING):
            given = options[key] is not None and not (key == "off_when_no_power" and options[key] is False)
            if key in needed and options[key] is None:
                raise self.error(f"needed with mode = \"{mode}\"", key)
            if given and key not in needed and not (mode in self.SERVODYN and key in self.SWITCHING):
                raise self.error(f"not used with mode = \"{mode}\"", key)
        if options["on_time"] is not None and options["on_speed_rpm"] is not None:
            raise self.error("give on_time or on_speed_rpm, not both", "on_speed_rpm")
        from modesel.turbine import servodyn as sd
        if mode == "simple_variable_speed":
            w_rated = options["rated_speed_rpm"] * sd.RPM
            k2 = options["region2_k"] / sd.RPM**2
            self.law = (sd.simple_vs_torque,
                        (w_rated, options["rated_torque"], k2)
                        + sd.simple_vs_constants(w_rated, options["rated_torque"], k2,
                                                 options["slip_percent"] / 100.0))
        elif mode == "induction":
            sync = options["sync_speed_rpm"] * sd.RPM
            rated = sync * (1.0 + options["slip_percent"] / 100.0)
            self.law = (sd.induction_torque, (sync, options["rated_torque"] / (rated - sync),
                                              options["pullout_ratio"] * (rated - sync),
                                              options["rated_torque"] * options["pullout_ratio"]))
        elif mode == "thevenin":
            if options["poles"] % 2:
                raise self.error(f"must be an even number, got {options['poles']:g}", "poles")
            self.law = (_sd.thevenin_torque_power,
                        _sd.thevenin_constants(*(options[k] for k in _sd.THEVENIN_INPUTS.values())))
        self.online_latched = False
        self.off_latched = False

    def configure(self, spec):
        if self.options["mode"] == "locked":
            if "GeAz" in spec.prescribed:
                raise self.error("a locked generator cannot turn at a constant speed", "mode")
            if "GeAz" in spec.free:
                spec.free.remove("GeAz")
            spec.fixed["GeAz"] = self.scene.initial.get("Azimuth", 0.0)

    def setup(self, built):
        self.i = built.eq.index["GeAz"]
        self.ratio = built.model.turbine.gearbox_ratio

    def torque(self, w):
        if self.options["mode"] == "constant":
            return self.options["torque"]
        return variable_speed_torque(w)

    def servodyn(self, t, w):
        """(torque [N m], electrical power [W]) of ServoDyn's laws with its
        on/off switching (module doc)."""
        from modesel.turbine.servodyn import electrical_power
        o = self.options
        if o["off_time"] is not None and t >= o["off_time"]:
            return 0.0, 0.0
        if self.off_latched:
            return 0.0, 0.0
        if o["on_speed_rpm"] is not None:
            if not self.online_latched and w * 30.0 / np.pi >= o["on_speed_rpm"]:
                self.online_latched = True
            if not self.online_latched:
                return 0.0, 0.0
        elif t < (o["on_time"] or 0.0):
            return 0.0, 0.0
        law, args = self.law
        if o["mode"] == "thevenin":
            T, P = law(w, *args)
        else:
            T = law(w, *args)
            P = electrical_power(T, w, o["efficiency"])
        if o["off_when_no_power"] and P <= 0.0:
            self.off_latched = True
            return 0.0, 0.0
        return T, P

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        w = self.ratio * qd_all[self.i]
        if self.options["mode"] in self.SERVODYN:
            T, P = self.servodyn(t, w)
        else:
            T = self.torque(w)
            P = T * w * self.options["efficiency"]
        generalized[self.i] -= self.ratio * T
        self.last = (T, P)

    def channels(self, built):
        if not self.last:
            return {}
        T, P = self.last
        return {"GenTq": T / 1e3, "GenPwr": P / 1e3}

    def compile_loads(self, built, packer, packed):
        """Pack this effect for the compiled loop (`effects.compiled`); the
        latches start as this effect's."""
        from modesel.model.effects.packing import GENERATOR
        law, lp, sw = self.compiled_parameters()
        o_f = packer.add(np.concatenate([[self.ratio], lp, sw]))
        o_s = packer.scratch(4)
        self.latch_slot = o_s
        packer.record(GENERATOR, [self.i, law, o_f, o_s])
        packer.channel("GenTq", o_s + 2, 1e-3)          # `_generator` writes T [N m], P [W]
        packer.channel("GenPwr", o_s + 3, 1e-3)
        packer.set_state(o_s, [float(self.online_latched), float(self.off_latched)])

    def compiled_parameters(self):
        """(law code, law parameters (LAW_PARAMETERS,), switches (6,)) of `switched_torque`
        for this effect's options (module doc; nan: switch not given)."""
        o = self.options
        mode = o["mode"]
        law = LAWS[mode]
        lp = np.zeros(LAW_PARAMETERS)
        if mode == "constant":
            lp[0] = o["torque"]
        elif mode in self.SERVODYN:
            lp[:len(self.law[1])] = self.law[1]
        nan = float("nan")
        sw = np.array([o["efficiency"], nan if o["on_time"] is None else o["on_time"],
                       nan if o["on_speed_rpm"] is None else o["on_speed_rpm"],
                       nan if o["off_time"] is None else o["off_time"],
                       1.0 if o["off_when_no_power"] else 0.0, 1.0 if mode in self.SERVODYN else 0.0])
        return law, lp, sw


#: law codes of `switched_torque`
LAWS = {"constant": 0, "variable_speed": 1, "simple_variable_speed": 2, "induction": 3, "thevenin": 4}
#: the length of a law's parameters (the Thevenin generator's 11, `servodyn.thevenin_constants`)
LAW_PARAMETERS = 11
_variable_speed_torque = njit(cache=True)(variable_speed_torque)
_simple_vs_torque = njit(cache=True)(_sd.simple_vs_torque)
_induction_torque = njit(cache=True)(_sd.induction_torque)
_thevenin_torque_power = njit(cache=True)(_sd.thevenin_torque_power)
_electrical_power = njit(cache=True)(_sd.electrical_power)


@njit(cache=True)
def switched_torque(t, w, law, lp, sw, latch):
    """Compiled twin of `Generator.__call__`'s torque and power (T [N m],
    P [W]) at time t [s] and HSS speed w [rad/s]: law (`LAWS`) with
    parameters lp (constant: torque; ServoDyn laws: their arguments after
    w; the Thevenin generator's power is its own, not from the efficiency),
    sw = (efficiency, on_time, on_speed_rpm, off_time,
    off_when_no_power, ServoDyn switching on) with nan for a switch not
    given, latch = (on-speed latched, off latched), updated in place. The
    laws themselves are the same functions as the Python path's, compiled."""
    P = 0.0
    if law == 0:
        T = lp[0]
    elif law == 1:
        T = _variable_speed_torque(w)
    elif law == 2:
        T = _simple_vs_torque(w, lp[0], lp[1], lp[2], lp[3], lp[4], lp[5])
    elif law == 3:
        T = _induction_torque(w, lp[0], lp[1], lp[2], lp[3])
    else:
        T, P = _thevenin_torque_power(w, lp[0], lp[1], lp[2], lp[3], lp[4], lp[5], lp[6], lp[7], lp[8], lp[9],
                                      lp[10])
    if sw[5] == 0.0:
        return T, T * w * sw[0]
    if not np.isnan(sw[3]) and t >= sw[3]:
        return 0.0, 0.0
    if latch[1] != 0.0:
        return 0.0, 0.0
    if not np.isnan(sw[2]):
        if latch[0] == 0.0 and w * 30.0 / np.pi >= sw[2]:
            latch[0] = 1.0
        if latch[0] == 0.0:
            return 0.0, 0.0
    elif t < (0.0 if np.isnan(sw[1]) else sw[1]):
        return 0.0, 0.0
    if law != 4:
        P = _electrical_power(T, w, sw[0])
    if sw[4] != 0.0 and P <= 0.0:
        latch[1] = 1.0
        return 0.0, 0.0
    return T, P


EFFECT = Generator
