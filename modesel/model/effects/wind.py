"""Wind: steady or time-varying uniform wind with power-law shear
(`aero.Wind`), the input of the `aero` and `tower_drag` effects.

    [effects.wind]
    speed = 11.4                 # m/s at the reference height
    shear = 0.0                  # power-law exponent (0.2: IEC normal wind profile)
    reference_height = 90.0      # m above ground (default: the rotor apex at rest)
    direction_deg = 0.0          # deg, from x (downwind) towards y
    time_series = [[0.0, 8.0], [60.0, 12.0]]   # optional (t [s], U [m/s]), replaces speed

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
        "shear": Option("number", 0.0, "power-law exponent [-]"),
        "reference_height": Option("number", None, "reference height [m]", positive=True),
        "direction_deg": Option("number", 0.0, "direction [deg]", scale=np.pi / 180.0),
        "time_series": Option("series", None, "(time [s], speed [m/s]) pairs"),
    }

    def __init__(self, scene, options):
        super().__init__(scene, options)
        if (options["speed"] is None) == (options["time_series"] is None):
            raise self.error("give either speed or time_series", "speed")

    def setup(self, built):
        o = self.options
        z_ref = o["reference_height"] if o["reference_height"] is not None else built.hub_height()
        series = None if o["time_series"] is None else o["time_series"].T
        self.field = Wind(o["speed"] or 0.0, o["shear"], z_ref, series, o["direction_deg"])


EFFECT = WindField
