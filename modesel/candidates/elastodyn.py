"""`elastodyn`: the deck's own mode-shape polynomials (bending).

ElastoDyn describes each bending mode by the coefficients a_2 .. a_6 of
x^2 .. x^6 (TwFAM1Sh, TwSSM2Sh, BldFl1Sh, BldEdgSh, ...), normalised by
their sum so that the tip value is 1 (first paper, eq. 46):

    phi = sum_j a_j x^j / sum_j a_j.

Available counts are what the deck has: tower_fa and tower_ss 2, blade_flap 2,
blade_edge 1. The coefficients come from `FieldContext.elastodyn_coefficients`
(filled from `Turbine.elastodyn_shapes` by `field_context`).
"""
from __future__ import annotations

import numpy as np

from modesel.candidates.base import BENDING_FIELDS, Family, register
from modesel.candidates.power_series import power_series, tip_normalised
from modesel.errors import ModeselError

POWERS = np.arange(2, 7)   # x^2 .. x^6


@register
class ElastoDyn(Family):
    name = "elastodyn"
    description = ("the deck's polynomial mode shapes (x^2..x^6 normalised by the coefficient sum, "
                   "eq. 46 of the first paper); tower 2 + 2, blade flap 2, edge 1")
    fields = BENDING_FIELDS
    max_count = 2
    field_max_counts = {"blade_edge": 1}   # ElastoDyn's slots: BldEdgSh only

    def evaluate(self, x, count, context, params):
        where = dict(file=context.source, field=context.field)
        coeffs = context.elastodyn_coefficients
        if coeffs is None or len(coeffs) == 0:
            raise ModeselError("no ElastoDyn mode-shape coefficients for this field "
                               "(family 'elastodyn' needs a turbine deck)", **where)
        if count > len(coeffs):
            raise ModeselError(f"the deck has {len(coeffs)} ElastoDyn mode shape(s) for this field, "
                               f"asked for {count}", **where)
        try:
            a = np.array([np.asarray(c, dtype=float).ravel() for c in coeffs[:count]])
        except (TypeError, ValueError):   # ragged or non-numeric
            a = None
        if a is None or a.shape != (count, len(POWERS)) or not np.all(np.isfinite(a)):
            raise ModeselError("ElastoDyn mode-shape coefficients must be 5 finite numbers "
                               "(x^2..x^6) per mode", **where)
        tip = a.sum(axis=1)
        if np.any(np.abs(tip) < 1e-9 * np.abs(a).sum(axis=1)):
            raise ModeselError("ElastoDyn mode-shape coefficients sum to zero; the shape cannot be "
                               "normalised to a unit tip (eq. 46)", **where)
        return tip_normalised(*power_series(x, a, POWERS), tip)
