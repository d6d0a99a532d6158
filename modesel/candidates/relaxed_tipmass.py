"""`relaxed_tipmass`: eigenfunctions of a uniform cantilever carrying a tip
mass and a tip rotary inertia (bending).

Relaxes the free-end conditions of `clamped` in a physical way: at the tip
the bending moment and shear force no longer vanish but balance the inertia
of a rigid tip body (a rotor-nacelle assembly on a tower, a tip brake on a
blade):

    phi''(1) = eta b^4 phi'(1),   phi'''(1) = -mu b^4 phi(1),

with mu = `mass_ratio` = M_tip / (m L) and eta = `inertia_ratio` =
J_tip / (m L^3) as continuous parameters. Roots of the characteristic
equation are found by a sign-change scan plus Brent refinement and the
shapes are evaluated in exponentially scaled form (see
`modesel.candidates.cantilever`). mu = eta = 0 gives `clamped`. Shapes are
tip-normalised; for large mu the higher modes have small tip motion (the
tip mass acts like a pin), so their interior amplitude is large.
NREL 5-MW tower for scale (`field_context`): mu = 1.006 (RNA 3.50e5 kg,
tower 3.47e5 kg), eta = 6.8e-4 (side-side) and 2.8e-3 (fore-aft).
"""
from __future__ import annotations

from modesel.candidates.base import BENDING_FIELDS, Family, Parameter, register
from modesel.candidates.cantilever import characteristic_roots, eigenfunctions


@register
class RelaxedTipMass(Family):
    name = "relaxed_tipmass"
    description = ("uniform cantilever eigenfunctions with tip mass ratio mu = M/(mL) and tip "
                   "inertia ratio eta = J/(mL^3); mu = eta = 0 is `clamped`")
    fields = BENDING_FIELDS
    parameters = (Parameter("mass_ratio", 0.0, 0.0, 5.0, "tip mass / beam mass, M_tip/(m L)"),
                  Parameter("inertia_ratio", 0.0, 0.0, 1.0,
                            "tip rotary inertia / (beam mass * L^2), J_tip/(m L^3)"))
    max_count = 30

    def evaluate(self, x, count, context, params):
        mu, eta = params["mass_ratio"], params["inertia_ratio"]
        return eigenfunctions(x, characteristic_roots(count, mu, eta), mu, eta)

    def canonical(self, field, count, params):
        """mu = eta = 0 is `clamped` (the free-end conditions of a bare cantilever)."""
        if params["mass_ratio"] == 0.0 and params["inertia_ratio"] == 0.0:
            return "clamped", int(count), {}
        return super().canonical(field, count, params)
