"""Wind: InflowWind's uniform wind (`aero.Wind`), steady or tabulated in
time, the input of the `aero` and `tower_drag` effects.

    [effects.wind]
    speed = 11.4                 # m/s at the reference height
    shear = 0.0                  # power-law exponent (0.2: IEC normal wind profile)
    reference_height = 90.0      # m above ground (default: the rotor apex at rest)
    direction_deg = 0.0          # deg, from x (downwind) towards y
    time_series = [[0.0, 8.0], [60.0, 12.0]]   # optional (t [s], U [m/s]), replaces speed

or an InflowWind uniform wind file (WindType 2; its columns give speed,
direction, vertical speed, shears, gust and upflow in time, interpolated
linearly; `inflowwind.read_uniform_wind`):

    file = "wind.hh"             # relative to the scene
    reference_height = 90.0      # RefHt_Uni [m]
    reference_length = 125.88    # RefLength [m] of the linear shears

or a TurbSim full field (InflowWind WindType 3: frozen turbulence on a
grid, `aero.full_field`):

    full_field = "turb.bts"      # relative to the scene
    direction_deg = 10.0         # optional: the field turned about the vertical through the hub

A uniform wind (not a full field; without direction_deg) can be tilted as
InflowWind's VFlowAng tilts it, about the hub point (`aero.wind`):

    upflow_deg = 8.0             # deg, the flow turned upwards

The wind itself applies no load.
"""
from __future__ import annotations

import numpy as np

from modesel.aero.wind import Wind
from modesel.model.effects.base import Effect, Option


class WindField(Effect):
    name = "wind"
    OPTIONS = {
        "speed": Option("number", None, "reference-height speed [m/s]", nonnegative=True),
        "shear": Option("number", None, "power-law exponent [-]"),
        "reference_height": Option("number", None, "reference height [m]", positive=True),
        "direction_deg": Option("number", None, "direction [deg]", scale=np.pi / 180.0),
        "time_series": Option("series", None, "(time [s], speed [m/s]) pairs"),
        "file": Option("path", None, "InflowWind uniform wind file"),
        "reference_length": Option("number", None, "RefLength of the linear shears [m]", positive=True),
        "full_field": Option("path", None, "TurbSim full-field file (.bts)"),
        "upflow_deg": Option("number", None, "InflowWind's VFlowAng: the uniform field tilted about the hub "
                                              "point [deg]", scale=np.pi / 180.0),
    }

    def __init__(self, scene, options):
        super().__init__(scene, options)
        o = options
        self.full_field = None
        if o["full_field"] is not None:
            for key in ("speed", "shear", "time_series", "file", "reference_length", "upflow_deg"):
                if o[key] is not None:
                    raise self.error("given by the full field: leave it out with full_field", key)
            from modesel.aero.full_field import read_turbsim
            self.full_field = read_turbsim(o["full_field"])
            self.table = None
        elif o["file"] is not None:
            for key in ("speed", "shear", "direction_deg", "time_series"):
                if o[key] is not None:
                    raise self.error("given by the wind file's columns: leave it out with file", key)
            from modesel.turbine.inflowwind import read_uniform_wind
            self.table = read_uniform_wind(o["file"])
        else:
            if (o["speed"] is None) == (o["time_series"] is None):
                raise self.error("give either speed or time_series (or a file)", "speed")
            if o["reference_length"] is not None:
                raise self.error("only used with a wind file", "reference_length")
            self.table = None

    def setup(self, built):
        o = self.options
        if o["upflow_deg"] and o["direction_deg"]:
            raise self.error("an upflow with a direction is not modelled (InflowWind turns the field by both "
                             "about the hub point)", "upflow_deg")
        if self.full_field is not None:
            self.field = Wind(reference_height=self.full_field.hub_height, full_field=self.full_field,
                              direction=o["direction_deg"] or 0.0)
            return
        z_ref = o["reference_height"] if o["reference_height"] is not None else built.hub_height()
        if self.table is not None:
            self.field = Wind(reference_height=z_ref, table=self.table,
                              reference_length=o["reference_length"] or 1.0, upflow=o["upflow_deg"] or 0.0)
            return
        series = None if o["time_series"] is None else o["time_series"].T
        self.field = Wind(o["speed"] or 0.0, o["shear"] or 0.0, z_ref, series, o["direction_deg"] or 0.0,
                          upflow=o["upflow_deg"] or 0.0)

    def check_covers(self, built, tmax):
        """With a full field: a one-line ModeselError where the rotor at rest
        (hub height, the aero effect's tip radius) or a run of tmax [s] leaves
        the field (`FullField.check_covers`), before anything is integrated."""
        if self.full_field is None:
            return
        aero = built.effect("aero")
        radius = aero.bem.solver.tip_radius if aero is not None and hasattr(aero, "bem") else 0.0
        self.full_field.check_covers(built.hub_height(), radius, tmax, turn=self.options["direction_deg"] or 0.0)


EFFECT = WindField
