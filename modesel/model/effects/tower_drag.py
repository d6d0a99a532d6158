"""Quasi-steady tower drag on the moving tower (second paper eq. 51):

    p = 1/2 rho Cd(z) d(z) |v_rel| v_rel,   v_rel = wind(z, t) - v_tower(z)

per unit length (`aero.TowerDrag.load`), with the tower's own velocity at
each quadrature node from the engine's kinematics, applied as node forces
F_k = p(z_k) w_k (w_k the node quadrature weight). Diameter and Cd come from
the AeroDyn deck's tower table (TwrElev, TwrDiam, TwrCd), taken at the
nodes' heights at rest (the tower shortens by centimetres at most); the
wind is evaluated at the nodes' current heights. No tower shadow on the
blades. Needs [effects.wind]. `drag_forces` is the compiled twin of
`aero.TowerDrag.load` (tests hold them equal).

    [effects.tower_drag]
    aerodyn = "path/to/AeroDyn.dat"   # default: the aero effect's deck / the built-in one
"""
from __future__ import annotations

import numpy as np
from numba import njit

from modesel.aero.wind import wind_velocity
from modesel.model.effects.aero import aerodyn_deck, wind_of
from modesel.model.effects.base import Effect, Option
from modesel.multibody.kinematics import PointSet


class TowerDragLoads(Effect):
    name = "tower_drag"
    loads = True
    OPTIONS = {"aerodyn": Option("path", None, "AeroDyn main file (tower table)")}

    def setup(self, built):
        self.wind = wind_of(self, built)
        aero = built.effect("aero")
        if self.options["aerodyn"] is None and aero is not None:
            deck = aero.deck
        else:
            deck = aerodyn_deck(self)
        if deck.tower is None:
            raise self.error("the AeroDyn deck has no tower table (TwrElev, TwrDiam, TwrCd)", "aerodyn")
        self.drag = deck.tower
        self.rho = (aero.bem.solver.air_density if aero is not None and self.options["aerodyn"] is None
                    else deck.air_density)
        self.nodes = PointSet.of_body(built.eq, "tower")
        z_rest = self.nodes.kinematics(built.frames(*_rest(built)), *_rest(built))[0][:, 2]
        d, cd = self.drag.properties(z_rest)
        self.coef = 0.5 * self.rho * cd * d * np.asarray(built.model.weights["tower"], float)
        self.force = np.empty((len(z_rest), 3))

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        pos, vel = self.nodes.kinematics(built.frames(q_all, qd_all), q_all, qd_all)
        drag_forces(pos, vel, self.wind.params(t), self.coef, self.force)
        f = node_forces.get("tower")
        node_forces["tower"] = self.force if f is None else f + self.force   # overwritten next call


def _rest(built):
    """All coordinates and rates of the undeflected turbine at rest."""
    n = built.eq.n_all
    return built.eq.fixed_values.copy(), np.zeros(n)


@njit(cache=True)
def drag_forces(pos, vel, wp, coef, out):
    """Eq. 51 at every node: out_k = coef_k |v_rel| v_rel with v_rel the
    horizontal wind at the node (`aero.wind.wind_velocity`, parameters wp)
    minus the node's horizontal velocity; coef_k = 1/2 rho Cd d w_k (AeroDyn's
    TwrAero load, ADTwr_CalcOutput: the components normal to the tower)."""
    for k in range(pos.shape[0]):
        u0, u1, _ = wind_velocity(wp, pos[k, 0], pos[k, 1], pos[k, 2])
        v0 = u0 - vel[k, 0]
        v1 = u1 - vel[k, 1]
        s = coef[k] * np.sqrt(v0 * v0 + v1 * v1)
        out[k, 0] = s * v0
        out[k, 1] = s * v1
        out[k, 2] = 0.0

EFFECT = TowerDragLoads
