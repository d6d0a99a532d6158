"""`cosine`: 1 - cos((2k - 1) pi x / 2) (bending).

Mode 1 is MF2 of the second paper (eq. 53-54). Every shape has
phi(0) = phi'(0) = 0, phi(1) = 1 and phi''(1) = 0, but phi'''(1) != 0: the
free-end shear condition is relaxed.
"""
from __future__ import annotations

import numpy as np

from modesel.candidates.base import BENDING_FIELDS, Family, register


@register
class Cosine(Family):
    name = "cosine"
    description = "1 - cos((2k-1) pi x/2); mode 1 = MF2 (eq. 53-54); free-end shear relaxed"
    fields = BENDING_FIELDS
    max_count = 50

    def evaluate(self, x, count, context, params):
        a = ((2 * np.arange(1, count + 1) - 1) * np.pi / 2)[:, None]
        ax = a * np.asarray(x, dtype=float)[None, :]
        return 1.0 - np.cos(ax), a * np.sin(ax), a * a * np.cos(ax)
