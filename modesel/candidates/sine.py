"""`sine`: torsion modes of a uniform shaft carrying a rigid tip inertia.

phi_k(x) = sin(g_k x) / sin(g_k), where g_k is the k-th positive root of

    g tan g = 1 / rho,     rho = `inertia_ratio` = J_tip / (I_p L),

J_tip the tip (yaw) inertia, I_p the shaft's polar mass moment of inertia per
unit length and L its length. This follows from GJ phi'' + I_p w^2 L^2 phi = 0,
phi(0) = 0 and the tip balance GJ phi'(1)/L = J_tip w^2 phi(1).
Root k lies in ((k - 1) pi, (k - 1/2) pi), found by Brent's method.
rho -> 0 gives the bare clamped-free shaft (`clamped`: g_k = (2k-1) pi/2);
rho -> infinity turns mode 1 into the linear twist x (`linear`), the higher
modes into clamped-clamped sines. The default rho = 2.5 is the NREL 5-MW
tower under its rotor-nacelle assembly (2.66 with `field_context`'s RNA yaw
inertia 5.96e6 kg m^2 and the tower's 2.24e6 kg m^2); the range stops at 50
because the tip of mode k >= 2 then barely moves (sin g_2 ~ 1/(pi rho)) and
the tip-normalised shapes grow large.
"""
from __future__ import annotations

import numpy as np

from modesel.candidates.base import TORSION_FIELDS, Family, Parameter, register


def tip_inertia_shaft_roots(count: int, rho: float) -> np.ndarray:
    """First `count` roots of cos g - rho g sin g = 0 (i.e. g tan g = 1/rho)."""
    from scipy.optimize import brentq        # here: every build loads the families (module doc of base)
    f = lambda g: np.cos(g) - rho * g * np.sin(g)  # noqa: E731
    return np.array([brentq(f, (k - 1) * np.pi, (k - 0.5) * np.pi, xtol=1e-15, rtol=1e-15)
                     for k in range(1, count + 1)])


@register
class Sine(Family):
    name = "sine"
    description = ("torsion: sin(g_k x)/sin(g_k), g tan g = 1/rho: uniform shaft with tip inertia "
                   "ratio rho = J_tip/(I_p L) (rho->0: clamped, rho->inf: mode 1 linear)")
    fields = TORSION_FIELDS
    parameters = (Parameter("inertia_ratio", 2.5, 0.1, 50.0,
                            "tip inertia / shaft polar inertia, J_tip/(I_p L)"),)
    max_count = 30

    def evaluate(self, x, count, context, params):
        g = tip_inertia_shaft_roots(count, params["inertia_ratio"])[:, None]
        gx = g * np.asarray(x, dtype=float)[None, :]
        tip = np.sin(g)
        return np.sin(gx) / tip, g * np.cos(gx) / tip, -g * g * np.sin(gx) / tip
