"""Drivetrain torsion, in one of two forms (model/template.py documents the bodies).

"elastodyn" (default): one torsional spring/damper between the rotor
(angle GeAz + DrTr) and the generator (GeAz), ElastoDyn's DTTorSpr and
DTTorDmp on the LSS:

    Q_DrTr = -k DrTr - c DrTr'

"two_spring": the second paper's low- and high-speed shafts with a rigid
gearbox (eq. 19 and 47): potential and Rayleigh function

    V = 1/2 k_LSS (DrTr - HSSTw)^2 + 1/2 k_HSS (N_g HSSTw)^2
    R = 1/2 c_LSS (DrTr' - HSSTw')^2 + 1/2 c_HSS (N_g HSSTw')^2

with HSSTw the HSS twist referred to the LSS (theta_1 - GeAz). Eq. 47 prints
R without the factor 1/2; the usual Rayleigh function (damping torque
c * twist rate) is used here. Defaults: the two shafts share the deck's
LSS-referred compliance equally, k_LSS = N_g^2 k_HSS = 2 DTTorSpr and
c_LSS = N_g^2 c_HSS = 2 DTTorDmp (in series: DTTorSpr and DTTorDmp again),
and the gearbox inertia (LSS side, not in the ElastoDyn deck) is 10 % of the
generator's LSS-referred inertia GenIner N_g^2 (an assumption: give
`gearbox_inertia` for a real gearbox).

    [effects.drivetrain]
    model = "two_spring"          # or "elastodyn"
    lss_stiffness = 1.735e9       # N m/rad          lss_damping = 1.243e7   # N m s/rad
    hss_stiffness = 1.844e5       # N m/rad (HSS)    hss_damping = 1321.0    # N m s/rad (HSS)
    gearbox_inertia = 5.0e5       # kg m^2 (LSS side)

Both forms are linear spring-dampers, so a scene whose only loads are these
runs entirely in the compiled integrator. Needs DrTr in [dofs] free; on by
default when it is.
"""
from __future__ import annotations

from modesel.model.effects.base import Effect, Option

GEARBOX_INERTIA_FRACTION = 0.1


class Drivetrain(Effect):
    name = "drivetrain"
    OPTIONS = {
        "model": Option("choice", "elastodyn", "drivetrain form", choices=("elastodyn", "two_spring")),
        "lss_stiffness": Option("number", None, "LSS torsional stiffness [N m/rad]", positive=True),
        "hss_stiffness": Option("number", None, "HSS torsional stiffness [N m/rad]", positive=True),
        "lss_damping": Option("number", None, "LSS torsional damping [N m s/rad]", nonnegative=True),
        "hss_damping": Option("number", None, "HSS torsional damping [N m s/rad]", nonnegative=True),
        "gearbox_inertia": Option("number", None, "gearbox inertia, LSS side [kg m^2]", positive=True),
    }

    @classmethod
    def default_on_for(cls, scene):
        return "DrTr" in scene.free

    def configure(self, spec):
        if "DrTr" not in spec.free:
            raise self.error("the drivetrain needs DrTr in [dofs] free")
        t = self.scene.turbine
        N = t.gearbox_ratio
        o = self.options
        if o["model"] == "two_spring":
            if t.gearbox_efficiency < 1.0:
                raise self.error(f"gearbox losses (efficiency {t.gearbox_efficiency * 100:g} %, ElastoDyn's "
                                 f"GBoxEff) are modelled with model = \"elastodyn\" only", "model")
            spec.drivetrain = "two_spring"
            spec.free.append("HSSTw")
            spec.gearbox_inertia = (o["gearbox_inertia"] if o["gearbox_inertia"] is not None
                                    else GEARBOX_INERTIA_FRACTION * t.generator_inertia * N**2)
            self.k_lss = o["lss_stiffness"] if o["lss_stiffness"] is not None else 2 * t.drivetrain_stiffness
            self.c_lss = o["lss_damping"] if o["lss_damping"] is not None else 2 * t.drivetrain_damping
            # HSS values referred to the LSS (times N_g^2)
            self.k_hss = (o["hss_stiffness"] * N**2 if o["hss_stiffness"] is not None
                          else 2 * t.drivetrain_stiffness)
            self.c_hss = (o["hss_damping"] * N**2 if o["hss_damping"] is not None
                          else 2 * t.drivetrain_damping)
        else:
            for key in ("hss_stiffness", "hss_damping", "gearbox_inertia"):
                if o[key] is not None:
                    raise self.error("only used with model = \"two_spring\"", key)
            self.k_lss = o["lss_stiffness"] if o["lss_stiffness"] is not None else t.drivetrain_stiffness
            self.c_lss = o["lss_damping"] if o["lss_damping"] is not None else t.drivetrain_damping

    def linear(self, built):
        kl, cl = self.k_lss, self.c_lss
        if self.options["model"] == "elastodyn":
            return [("DrTr", "DrTr", kl, cl)]
        kh, ch = self.k_hss, self.c_hss
        return [("DrTr", "DrTr", kl, cl), ("DrTr", "HSSTw", -kl, -cl),
                ("HSSTw", "DrTr", -kl, -cl), ("HSSTw", "HSSTw", kl + kh, cl + ch)]


EFFECT = Drivetrain
