"""Shapes written as power series sum_j a_j x^p_j, with exact derivatives.

Shared by the families whose shapes are polynomials (`polynomial`,
`elastodyn`, `relaxed_root`, `linear`).
"""
from __future__ import annotations

import numpy as np


def power_series(x, coefficients, powers):
    """Evaluate shapes phi_i(x) = sum_j coefficients[i, j] x**powers[j].

    `powers` must be >= 2 wherever second derivatives are needed at x = 0
    (a power 1 has a zero second derivative; powers in (0, 2) other than 1
    would be singular and are not used by any family).
    Returns (phi, dphi, ddphi), each (n_shapes, len(x)).
    """
    x = np.asarray(x, dtype=float)
    a = np.atleast_2d(np.asarray(coefficients, dtype=float))
    p = np.asarray(powers, dtype=float)
    basis = _monomials(x, p, 0)
    d1 = p[:, None] * _monomials(x, p, 1)
    d2 = (p * (p - 1))[:, None] * _monomials(x, p, 2)
    return a @ basis, a @ d1, a @ d2


def _monomials(x, powers, order):
    """x**(p - order) for each power, 0 where p - order < 0 (the factor
    multiplying it vanishes then), and 1 where p - order == 0."""
    out = np.zeros((len(powers), len(x)))
    for i, p in enumerate(powers):
        q = p - order
        if q == 0:
            out[i] = 1.0
        elif q > 0:
            out[i] = x ** q
    return out


def tip_normalised(phi, dphi, ddphi, tip):
    """Divide each shape (row) by its tip value `tip` (shape (n,))."""
    tip = np.asarray(tip, dtype=float)[:, None]
    return phi / tip, dphi / tip, ddphi / tip
