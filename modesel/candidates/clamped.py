"""`clamped`: eigenfunctions of a uniform clamped-free beam.

Bending fields: uniform Euler-Bernoulli cantilever modes,
phi_k = cosh b_k x - cos b_k x - sigma_k (sinh b_k x - sin b_k x) with
1 + cos b_k cosh b_k = 0 (b_1 = 1.8751: MF3 of eq. 53-54 of the second
paper, sigma_1 = 1/1.3622). Roots and shapes come from
`modesel.candidates.cantilever`, which evaluates them without catastrophic
cancellation for any k (mode 20 agrees with 80-digit arithmetic to 3e-15).

Torsion (tower_torsion): uniform clamped-free shaft modes
phi_k = sin((2k - 1) pi x / 2), scaled by (-1)^(k+1) to a unit tip.
"""
from __future__ import annotations

import numpy as np

from modesel.candidates.base import BENDING_FIELDS, TORSION_FIELDS, Family, register
from modesel.candidates.cantilever import clamped_free_roots, eigenfunctions


def clamped_free_torsion(x, count):
    """sin((2k-1) pi x / 2) / sin((2k-1) pi / 2), k = 1..count, with derivatives."""
    k = np.arange(1, count + 1)[:, None]
    a = (2 * k - 1) * np.pi / 2
    sign = np.where(k % 2 == 1, 1.0, -1.0)   # sin((2k-1) pi/2), exactly
    ax = a * np.asarray(x, dtype=float)[None, :]
    return sign * np.sin(ax), sign * a * np.cos(ax), -sign * a * a * np.sin(ax)


@register
class Clamped(Family):
    name = "clamped"
    description = ("uniform clamped-free beam eigenfunctions (1 + cos b cosh b = 0; mode 1 = MF3, "
                   "eq. 53-54); torsion: sin((2k-1) pi x/2)")
    fields = BENDING_FIELDS + TORSION_FIELDS
    max_count = 50   # stable for any k; 50 modes already need > 1000 stations to resolve

    def evaluate(self, x, count, context, params):
        if context.field in TORSION_FIELDS:
            return clamped_free_torsion(x, count)
        return eigenfunctions(x, clamped_free_roots(count))
