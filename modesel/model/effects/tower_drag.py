"""Quasi-steady tower drag on the moving tower (second paper eq. 51):

    p = 1/2 rho Cd(z) d(z) |v_rel| v_rel,   v_rel = wind(z, t) - v_tower(z)

per unit length (`aero.TowerDrag.load`, here its compiled twin
`aero.tower_drag.drag_forces`), evaluated as AeroDyn evaluates it
(ADTwr_CalcOutput): at the tower stations of the AeroDyn deck (TwrElev,
its tower nodes), with the tower's own velocity there and the wind at the
stations' current heights. As OpenFAST maps AeroDyn's tower line load onto
the structure, the load is linear in between: node k of the tower takes
F_k = w_k p(z_k) with p interpolated linearly between the stations
(`effects.aero.sampled_transfer`, w_k the node quadrature weight). Stations are the
table's elevations on the tower plus its base and top where the table does
not reach them (diameter and Cd are held constant beyond the table ends, so
the whole tower is loaded); diameter and Cd are the table's at the
stations. No tower shadow on the blades. Needs [effects.wind].

The node loads are T g of the station loads g (T the transfer, N x P), so
the compiled loop may take them at one load point per station
(`packing.with_load_points`, `Effect.load_points`): the tower's loaded
sums then run over its P stations instead of its N nodes.

    [effects.tower_drag]
    aerodyn = "path/to/AeroDyn.dat"   # default: the aero effect's deck / the built-in one
"""
from __future__ import annotations

import numpy as np

from modesel.aero.tower_drag import drag_forces
from modesel.model.effects.aero import aerodyn_deck, row_bands, sampled_transfer, wind_of
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
        self.elevation, local = self._stations(built)
        s0, Phi, S = built.model.station_shapes("tower", local - built.model.turbine.tower.root_offset)
        self.stations = PointSet.of_points(built.eq, "tower", s0, Phi, S)
        self.coef = self.drag.coefficient(self.elevation, self.rho)           # [kg/m^2]
        self.transfer = sampled_transfer(local, self.nodes.s0[:, 2], np.asarray(built.model.weights["tower"], float))
        self.line = np.empty((len(local), 3))                                  # p at the stations [N/m]

    def _stations(self, built):
        """Elevations [m] and body-frame heights [m] of the stations: the
        table's elevations on the tower, plus its base and top where the
        table does not reach them; heights at rest from the nodes' (the
        undeflected tower is straight)."""
        q, qd = _rest(built)
        z_rest = self.nodes.kinematics(built.frames(q, qd), q, qd)[0][:, 2]
        local = self.nodes.s0[:, 2]
        slope, base = np.polyfit(local, z_rest, 1) if len(local) > 1 else (1.0, z_rest[0] - local[0])
        tower = built.model.turbine.tower
        ends = np.array([tower.root_offset, tower.root_offset + tower.length])
        inside = (self.drag.elevation - base) / slope
        tol = 1e-6 * tower.length
        inside = inside[(inside > ends[0] + tol) & (inside < ends[1] - tol)]
        local = np.concatenate([ends[:1], inside, ends[1:]])
        return base + slope * local, local

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        pos, vel = self.stations.kinematics(built.frames(q_all, qd_all), q_all, qd_all)
        drag_forces(pos, vel, self.wind.params(t), self.coef, self.line)
        force = self.transfer @ self.line
        f = node_forces.get("tower")
        node_forces["tower"] = force if f is None else f + force

    def load_points(self, built):
        """The tower's node loads are T p of the station loads p (module doc)."""
        return {"tower": self.transfer}

    def compile_loads(self, built, packer, packed):
        """Pack this effect for the compiled loop (`effects.compiled._tower_drag`):
        the station loads carried to the tower's load points (weights w_a)
        where `packed` has them, else to its nodes (the transfer's bands)."""
        from modesel.model.effects.packing import TOWER_DRAG, point_set_ints
        lp = packed.load_points.get("tower")
        if lp is not None:
            band, first, start = lp.weights[:, None], np.arange(len(lp.weights)), lp.first
        else:
            (band, first), start = row_bands(self.transfer), packed.node_rows("tower")[0]
        m = len(self.coef)
        ints = [start, band.shape[0], band.shape[1], packer.add(self.coef), packer.scratch(9 * m),
                packer.add(band)] + list(first)
        packer.record(TOWER_DRAG, ints + point_set_ints(packer, self.stations))


def _rest(built):
    """All coordinates and rates of the undeflected turbine at rest."""
    n = built.eq.n_all
    return built.eq.fixed_values.copy(), np.zeros(n)


EFFECT = TowerDragLoads
