"""Prescribed constant collective blade pitch (second paper eq. 26, beta).

    [effects.pitch]
    collective_deg = 10.45     # deg, positive towards feather

The pitch rotates every blade about its (coned) axis; the flap/edge shape
directions turn with it (they are defined in the pitched blade frame) and
the BEM angle of attack uses it (alpha = phi - pitch - twist). It overrides
[initial] BlPitch.
"""
from __future__ import annotations

import numpy as np

from modesel.model.effects.base import Effect, Option


class CollectivePitch(Effect):
    name = "pitch"
    OPTIONS = {"collective_deg": Option("number", 0.0, "collective pitch [deg]", scale=np.pi / 180.0)}

    def configure(self, spec):
        spec.pitch = self.options["collective_deg"]


EFFECT = CollectivePitch
