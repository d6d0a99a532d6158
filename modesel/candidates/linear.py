"""`linear`: phi_k = x^k (tower torsion).

Mode 1 is the linear twist phi = x: the limit of the first mode of a shaft
whose tip inertia dominates its own (the NREL 5-MW RNA yaw inertia is ~2.7
times the tower's polar inertia, close to that limit). Further modes continue the power sequence
x^2, x^3, ...: with x they span every polynomial that vanishes at the
clamped root (the only geometric condition in torsion), each has a unit tip
value, and none imposes a free-end condition. Like all monomial bases this
becomes ill-conditioned with count (the shape-integral layer orthonormalises).
"""
from __future__ import annotations

import numpy as np

from modesel.candidates.base import TORSION_FIELDS, Family, register
from modesel.candidates.power_series import power_series


@register
class Linear(Family):
    name = "linear"
    description = "torsion: phi_k = x^k (mode 1 the linear twist x; root condition only)"
    fields = TORSION_FIELDS
    max_count = 12

    def evaluate(self, x, count, context, params):
        return power_series(x, np.eye(count), np.arange(1, count + 1))
