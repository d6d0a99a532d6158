"""Piecewise Gauss-Legendre quadrature on the station intervals of a beam.

    int_0^L f(s) ds  ~=  sum_k w_k f(s_k)

with `points_per_interval` Gauss-Legendre points in each interval
[s_i, s_i+1] between consecutive stations: s_k = (s_i + s_i+1)/2 +
(s_i+1 - s_i)/2 x_g, w_k = (s_i+1 - s_i)/2 w_g for the Gauss points x_g and
weights w_g on [-1, 1] (exact for polynomials of degree <= 2 n - 1 inside
an interval, n points). Used by the shape integrals and by the flexible
beam bodies of the turbine model (their nodes carry the mass).
"""
from __future__ import annotations

import numpy as np


def gauss_legendre(stations, points_per_interval: int):
    """(s [m], w [m]): points and weights of `points_per_interval` Gauss-Legendre
    points inside each interval of increasing `stations` [m], flattened in
    station order."""
    span = np.asarray(stations, dtype=float)
    xg, wg = np.polynomial.legendre.leggauss(int(points_per_interval))
    a, b = span[:-1, None], span[1:, None]
    s = 0.5 * (a + b) + 0.5 * (b - a) * xg
    w = 0.5 * (b - a) * wg
    return s.ravel(), w.ravel()
