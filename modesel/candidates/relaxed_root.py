"""`relaxed_root`: shapes held only by the geometric root conditions (bending).

The second paper (section 5) finds that *relaxing* the boundary conditions of
the assumed modes - satisfying the free-end conditions only approximately -
improves the response accuracy. This family makes that relaxation a
continuous parameter w = `free_end_weight` in [0, 1]:

    phi_k = (1 - w) x^(k+1) + w p_k(x),     k = 1, 2, ...

where p_k is mode k of the `polynomial` family (the tip-normalised
polynomial x^(k+1) + a x^(k+2) + b x^(k+3) that also satisfies the natural
free-end conditions phi''(1) = phi'''(1) = 0). Both terms start at x^(k+1)
and have a unit tip, so every blend satisfies phi(0) = phi'(0) = 0 and
phi(1) = 1, and the free-end residuals shrink linearly with w:
phi''(1) = (1 - w) k (k + 1), phi'''(1) = (1 - w)(k + 1) k (k - 1).
w = 0 (default) is the plain monomial sequence x^2, x^3, ... (free end
unconstrained; x^2 is the uniform-moment deflection, x^3 the tip-load
one); w = 1 reproduces `polynomial`. Why this blend: it keeps the space
spanned polynomial (exact shape integrals, no extra roots to find) and turns
"how much the free-end conditions are enforced" into one number a search can
tune. Like `polynomial` the basis is monomial-like and ill-conditioned
(raw Gram condition ~1e9 at 6 modes); the shape-integral layer orthonormalises.
"""
from __future__ import annotations

import numpy as np

from modesel.candidates.base import BENDING_FIELDS, Family, Parameter, register
from modesel.candidates.polynomial import clamped_free_polynomial_coefficients
from modesel.candidates.power_series import power_series


@register
class RelaxedRoot(Family):
    name = "relaxed_root"
    description = ("root conditions only: (1-w) x^(k+1) + w * polynomial mode k; w blends in the "
                   "free-end conditions (w=0: x^2, x^3, ...; w=1: polynomial family)")
    fields = BENDING_FIELDS
    parameters = (Parameter("free_end_weight", 0.0, 0.0, 1.0,
                            "weight w of the clamped-free polynomial; the free-end moment and shear "
                            "residuals scale with 1 - w"),)
    max_count = 12

    def evaluate(self, x, count, context, params):
        w = params["free_end_weight"]
        coeffs, powers = clamped_free_polynomial_coefficients(count)
        coeffs = w * coeffs / coeffs.sum(axis=1, keepdims=True)
        coeffs[np.arange(count), np.arange(count)] += 1.0 - w   # (1 - w) x^(k+1)
        return power_series(x, coeffs, powers)

    def canonical(self, field, count, params):
        """w = 1 is `polynomial` (every free-end condition enforced)."""
        if params["free_end_weight"] == 1.0:
            return "polynomial", int(count), {}
        return super().canonical(field, count, params)
