"""Yaw spring and damper: ServoDyn's yaw moment on ElastoDyn's yaw DOF.

    [effects.yaw]
    stiffness = 9.02832e9     # N m/rad        (ServoDyn YawSpr)
    damping = 1.916e7         # N m s/rad      (ServoDyn YawDamp)
    neutral_deg = 0.0         # deg            (ServoDyn YawNeut)

Without yaw control (ServoDyn YCMode = 0, no override manoeuvre) ServoDyn
commands the neutral yaw and zero yaw rate, and its yaw moment on the
nacelle about the yaw axis is (ServoDyn.f90 Yaw_CalcOutput)

    YawMom = -YawSpr (Yaw - YawNeut) - YawDamp Yaw'

which ElastoDyn adds to the generalised force of its yaw DOF (ElastoDyn.f90,
the yaw row of the right-hand side). A linear spring-damper, so a scene
whose only loads are these runs entirely in the compiled integrator. Needs
Yaw in [dofs] free; an OpenFAST case with YawDOF and ServoDyn switches it on
(`simulation.fst`); a free yaw without it turns without restoring moment.
"""
from __future__ import annotations

import numpy as np

from modesel.model.effects.base import Effect, Option


class YawSpring(Effect):
    name = "yaw"
    OPTIONS = {
        "stiffness": Option("number", None, "yaw spring constant, ServoDyn YawSpr [N m/rad]", nonnegative=True),
        "damping": Option("number", 0.0, "yaw damping constant, ServoDyn YawDamp [N m s/rad]", nonnegative=True),
        "neutral_deg": Option("number", 0.0, "neutral yaw, ServoDyn YawNeut [deg]", scale=np.pi / 180.0),
    }

    def configure(self, spec):
        if "Yaw" not in spec.free:
            raise self.error("the yaw spring needs Yaw in [dofs] free")
        if self.options["stiffness"] is None:
            raise self.error("give the yaw spring constant (ServoDyn YawSpr) [N m/rad]", "stiffness")

    def linear(self, built):
        o = self.options
        return [("Yaw", "Yaw", o["stiffness"], o["damping"], o["neutral_deg"])]


EFFECT = YawSpring
