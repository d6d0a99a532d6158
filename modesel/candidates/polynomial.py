"""`polynomial`: clamped-free polynomials of increasing degree (bending).

Mode 1 is MF1 of the second paper (eq. 53-54), the static deflection of a
uniform cantilever under a uniform load, scaled to a unit tip:

    phi_1 = x^4/3 - 4 x^3/3 + 2 x^2.

Mode k (m = k + 1) is the lowest-degree polynomial starting at x^m that
satisfies all four cantilever conditions phi(0) = phi'(0) = 0 (geometric,
at the root) and phi''(1) = phi'''(1) = 0 (natural, free end):

    p_k = x^m + a x^(m+1) + b x^(m+2),
    a = -2 (m - 1)/(m + 1),  b = m (m - 1)/((m + 1)(m + 2)),

(the two free-end conditions solved for a and b), divided by its tip value
1 + a + b; k = 1 gives MF1. Deliberately monomial-like and NOT
orthogonalised: the raw Gram matrix int phi_i phi_j dx has condition number
~1e9 at 6 modes, ~1e15 at 10, ~7e17 at 12 and ~6e20 at 14, the cap (exact
rational arithmetic): what the shape-integral layer's orthonormalisation is
tested on. (A QR of the sampled shapes loses only the square root of that.)
"""
from __future__ import annotations

import numpy as np

from modesel.candidates.base import BENDING_FIELDS, Family, register
from modesel.candidates.power_series import power_series, tip_normalised


def clamped_free_polynomial_coefficients(count: int):
    """(coefficients (count, count + 2), powers 2 .. count + 3) of p_1 .. p_count,
    before tip normalisation."""
    powers = np.arange(2, count + 4)
    coeffs = np.zeros((count, len(powers)))
    for k in range(1, count + 1):
        m = k + 1
        coeffs[k - 1, m - 2:m + 1] = (1.0, -2.0 * (m - 1) / (m + 1), m * (m - 1) / ((m + 1) * (m + 2)))
    return coeffs, powers


@register
class Polynomial(Family):
    name = "polynomial"
    description = ("clamped-free polynomials of increasing degree; mode 1 = MF1, the static "
                   "deflection under uniform load (eq. 53-54); monomial-like, ill-conditioned")
    fields = BENDING_FIELDS
    max_count = 14   # Gram condition ~6e20 at 14: beyond, numerically dependent even for QR

    def evaluate(self, x, count, context, params):
        coeffs, powers = clamped_free_polynomial_coefficients(count)
        return tip_normalised(*power_series(x, coeffs, powers), coeffs.sum(axis=1))
