"""Generator torque on the high-speed shaft.

    [effects.generator]
    mode = "variable_speed"     # | "constant" | "locked"
    torque = 43093.55           # N m on the HSS (mode "constant")
    efficiency = 0.944          # electrical efficiency for GenPwr

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

from modesel.model.effects.base import Effect, Option

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
    OPTIONS = {
        "mode": Option("choice", "variable_speed", "torque law",
                       choices=("variable_speed", "constant", "locked")),
        "torque": Option("number", None, "constant HSS torque [N m]"),
        "efficiency": Option("number", EFFICIENCY, "generator efficiency [-]", positive=True),
    }

    def __init__(self, scene, options):
        super().__init__(scene, options)
        mode = options["mode"]
        if (mode == "constant") != (options["torque"] is not None):
            raise self.error("give torque exactly when mode = \"constant\"", "torque")
        self.loads = mode != "locked"

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

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        w = self.ratio * qd_all[self.i]
        T = self.torque(w)
        generalized[self.i] -= self.ratio * T
        self.last = (T, w)

    def channels(self, built):
        if not self.last:
            return {}
        T, w = self.last
        return {"GenTq": T / 1e3, "GenPwr": T * w * self.options["efficiency"] / 1e3}


EFFECT = Generator
