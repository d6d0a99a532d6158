"""Quasi-steady tower drag on the moving tower (second paper eq. 51):

    p = 1/2 rho Cd(z) d(z) |v_rel| v_rel,   v_rel = wind(z, t) - v_tower(z)

per unit length (`aero.TowerDrag.load`, here its compiled twin
`aero.tower_drag.drag_forces`), evaluated as AeroDyn evaluates it
(ADTwr_CalcOutput): at the tower stations of the AeroDyn deck (TwrElev,
its tower nodes), with the tower's own velocity there and the wind at the
stations' current heights. As OpenFAST maps AeroDyn's tower line load onto
the structure, the load is linear in between. On ElastoDyn's tower nodes
(an OpenFAST case) node k takes the line load integrated over its element
(`effects.aero.cell_transfer`: OpenFAST sends each lumped piece of
AeroDyn's line to the nearest node, the one whose element it lies in); on a
quadrature, node k takes F_k = w_k p(z_k) (`effects.aero.sampled_transfer`,
w_k the node's weight). Stations are the
table's elevations on the tower, cut at the tower's base and top where the
table reaches beyond them; as in OpenFAST, whose mapping of AeroDyn's tower
line mesh onto ElastoDyn's loads only the span the two share, a node below
the table's lowest or above its highest elevation takes no drag. Diameter
and Cd are the table's at the stations. Air density: the aero effect's
(an OpenFAST case's AirDens, as for the rotor) where the drag takes its
deck, else the deck's. The tower's influence on the blades' wind (AeroDyn's
TwrPotent, TwrShadow) belongs to the aero effect (its tower_potential and
tower_shadow options), which takes AeroDyn's tower nodes from
`effects.aero.aerodyn_tower_stations`, as this effect does. Needs [effects.wind].

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
from modesel.model.effects.aero import (aerodyn_deck, aerodyn_tower_stations, cell_transfer, row_bands,
                                        sampled_transfer, wind_of)
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
        self.elevation, local, self.stations = aerodyn_tower_stations(self, built, self.drag.elevation)
        self.coef = self.drag.coefficient(self.elevation, self.rho)           # [kg/m^2]
        weights = np.asarray(built.model.weights["tower"], float)
        if built.model.tower_elastodyn_nodes:
            self.transfer = cell_transfer(local, self.nodes.s0[:, 2], weights)
        else:
            self.transfer = sampled_transfer(local, self.nodes.s0[:, 2], weights)
        self.line = np.empty((len(local), 3))                                  # p at the stations [N/m]

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        pos, vel = self.stations.kinematics(built.frames(q_all, qd_all), q_all, qd_all)
        drag_forces(pos, vel, self.wind.params(t), self.coef, self.line, True)
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


EFFECT = TowerDragLoads
