"""Quasi-steady tower drag on the moving tower (second paper eq. 51):

    p = 1/2 rho Cd(z) d(z) |v_rel| v_rel,   v_rel = wind(z, t) - v_tower(z)

per unit length (`aero.TowerDrag.load`, here its compiled twin
`aero.tower_drag.drag_forces`), with the tower's own velocity at each
quadrature node from the engine's kinematics, applied as node forces
F_k = p(z_k) w_k (w_k the node quadrature weight). Diameter and Cd come from
the AeroDyn deck's tower table (TwrElev, TwrDiam, TwrCd), taken at the
nodes' heights at rest (the tower shortens by centimetres at most); the
wind is evaluated at the nodes' current heights. No tower shadow on the
blades. Needs [effects.wind].

    [effects.tower_drag]
    aerodyn = "path/to/AeroDyn.dat"   # default: the aero effect's deck / the built-in one
"""
from __future__ import annotations

import numpy as np

from modesel.aero.tower_drag import drag_forces
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
        self.coef = self.drag.coefficient(z_rest, self.rho) * np.asarray(built.model.weights["tower"], float)
        self.force = np.empty((len(z_rest), 3))

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        pos, vel = self.nodes.kinematics(built.frames(q_all, qd_all), q_all, qd_all)
        drag_forces(pos, vel, self.wind.params(t), self.coef, self.force)
        f = node_forces.get("tower")
        node_forces["tower"] = self.force if f is None else f + self.force   # overwritten next call

    def compile_loads(self, built, packer, packed):
        """Pack this effect for the compiled loop (`effects.compiled`)."""
        from modesel.model.effects.packing import TOWER_DRAG, point_set_ints
        m = len(self.coef)
        ints = [packed.node_rows("tower")[0], packer.add(self.coef), packer.scratch(9 * m)]
        packer.record(TOWER_DRAG, ints + point_set_ints(packer, self.nodes))


def _rest(built):
    """All coordinates and rates of the undeflected turbine at rest."""
    n = built.eq.n_all
    return built.eq.fixed_values.copy(), np.zeros(n)


EFFECT = TowerDragLoads
