"""Blade aerodynamics by quasi-steady BEM on the moving, deflecting blades
(second paper section 3: BEM with Prandtl tip/hub loss, Buhl/Glauert and
Pitt-Peters skew; the work of the loads, eq. 52, enters as node forces).

    [effects.aero]
    aerodyn = "path/to/AeroDyn.dat"   # default for the built-in nrel5mw: its bundled deck
    skew = true                       # Pitt-Peters (default: the deck's SkewMod)
    pitching_moment = true            # Cm q c^2 as node moments (default: the deck's UseBlCm)
    tower_potential = "baseline"      # AeroDyn's TwrPotent: "none" (default), "baseline", "bak"
    tower_shadow = "powles"           # AeroDyn's TwrShadow: "none" (default), "powles", "eames"

Needs [effects.wind]. At every right-hand side:

1. Stations: the AeroDyn blade nodes, at the aerodynamic centres
   (BlCrvAC, BlSwpAC, BlSpn) of the pitched blade frame, as points of each
   flexible blade with the blade's own mode shapes evaluated there
   (`TurbineModel.station_shapes`); their inertial positions and
   velocities include all structural motion (tower, nacelle, rotor speed,
   blade vibration) through the engine's kinematics (`kinematics.py`).
2. Inflow (AeroDyn's legacy NoSweepPitchTwist projection, BEM_Mod 1):
   v_rel = wind(station, t) + dv - v_station, with dv the tower's influence
   (`aero.tower_influence`, AeroDyn's TwrInfl: potential flow around the
   tower and its shadow downstream, referred to AeroDyn's tower nodes on the
   deflected, moving tower; options tower_potential and tower_shadow, zero
   without them). An OpenFAST case takes them from the deck's TwrPotent and
   TwrShadow; a TOML scene only where it names them (the bundled NREL 5-MW
   deck says TwrPotent 1; the in-house scenes are held against OpenFAST
   runs made without it). With x_s the shaft axis and z_b
   the blade's (coned, pitched) axis, the coned normal is
   e_c = unit(x_s - (x_s . z_b) z_b) and the direction of rotation
   e_t = e_c x z_b. The deflected section's orientation is ElastoDyn's:
   the small-rotation vector (ThetaIP, ThetaOoP, 0) = (-g_y, g_x, 0) of the
   slopes g of the elastic displacement (`TurbineModel.station_slopes`) in
   the pitched blade frame, turned into a rotation by SmllRotTrans (Euler
   parameters (w, theta/2)) and applied to AeroDyn's reference orientation
   of the node (BlCrvAng, BlTwist, pitch: `section_reference`), as OpenFAST's
   mesh mapping does. AeroDyn's EulerExtract of it relative to the coned root
   frame gives the out-of-plane angle theta_2, which turns the annulus normal
   about the coned y axis, e_n = cos(theta_2) e_c - sin(theta_2) z_b, and the
   section's pitch + twist that the angle of attack uses (`inflow`); the
   latter carries the elastic twist ~ ThetaIP ThetaOoP / 2 of the combined
   flap and edge slopes (about 0.1 deg at the tip at 11.4 m/s), which lowers
   the outer sections' angle of attack with the flap deflection and swings
   with the gravity-driven edge deflection once per revolution.
   V_n = v_rel . e_n,
   V_t = -v_rel . e_t. The local radius r is the station's distance from
   the shaft axis (deflected); the Pitt/Peters radius ratio is r over the
   blade's largest r; the tip/hub loss constants use AeroDyn's zLocal.
3. Skew (Pitt-Peters): chi_0 is the angle between x_s and the
   disk-averaged relative wind (wind minus station velocity over all
   stations, AeroDyn's V_diskAvg); psi is each blade's azimuth from the
   in-plane direction of that wind. The rotor's tip-speed ratio (the hub's
   spin about x_s times the largest r_local over that wind along x_s) sets
   the weight of the inductions below TSR 2 (`bem.bem_weight`, AeroDyn's
   check_turnOffBEMT): a parked or starting rotor sees the geometric inflow.
4. BEM for all blades and stations at once -> f_n, f_t [N/m]:
   `BemSolver.solve_into` on buffers preallocated once (`StationBem`;
   `solve` allocates its result at every call, which costs as much as the
   solution itself here).
5. Loads: f = f_n e_n + f_t e_t per unit length at the stations,
   interpolated linearly in span to the blade's quadrature nodes and
   multiplied by the node quadrature weights w_k [m]: node force
   F_k = f(s_k) w_k, applied at the deflected node.
   Node moments (`node_moments`, AeroDyn -> ElastoDyn as OpenFAST maps
   them): the sectional pitching moment m = Cm q c^2 per unit length about
   the annulus z axis of the deflected section, e_z = e_t x e_n (AeroDyn's
   BEM_Mod 1 BladeLoad moment; with UseBlCm, option `pitching_moment`), and
   the moment of the forces about the aerodynamic centres' offsets from the
   blade axis (BlCrvAC, BlSwpAC), lumped like the forces and put on the
   node the load goes to. The engine applies a node moment through the
   blade's angular velocity (all rigid coordinates: azimuth, drivetrain,
   tower, ...); its work on the blade's bending coordinates is added here
   through ElastoDyn's partial angular velocity of the node (the mode's
   slope, in the pitched blade frame).
   On ElastoDyn's discrete blade nodes (`elastodyn_nodes`) the node forces
   are the lumped line loads (hat functions) carried by the transpose of
   the linear interpolation along the span (`_lumped_transfer`: total force
   and moment kept, so the rigid-body loads are exact), and the blade's
   elastic coordinates get the generalised forces of OpenFAST's mapping
   instead (`_elastodyn_correction`, `elastic_correction`): the AeroDyn line
   split where the ElastoDyn nodes project onto it (ModMesh's augmented
   mesh, `_augmented_line`), the line load lumped on it, each lumped point
   load moved to the nearest ElastoDyn node with the moment of its offset,
   and the element end moments of ModMesh's lumping, which ElastoDyn
   applies through the node's shape and slope.
   The compiled loop (`effects/compiled.py`) takes these node loads, where
   the blade's packing allows (`packing.with_load_points`), at one load
   point per station, the T-weighted mean of the nodes (T the transfer
   above: the same generalised forces, since every node sum is linear in
   the node's geometry), with the station's force w_a f_a and moment
   (`point_loads`): the blade's loaded sums then run over its M stations
   instead of its N nodes.

Channels (AeroDyn's names and units, see `channels`): RtAeroFxh [N] = sum
of node forces along x_s, RtAeroMxh [N m] = sum of their moments and the
node moments about x_s through the apex (the loads the structure receives), RtAeroPwr [W],
RtAeroCp [-]. (ElastoDyn's RotThrust and RotTorq are the shaft loads,
inertia and weight included: outputs.py.)

Options beyond the deck: `air_density` replaces the deck's AirDens (an
OpenFAST case passes the .fst AirDens where the deck says "default").
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from numba import njit

from modesel.errors import ModeselError
from modesel.model.effects.base import Effect, Option
from modesel.aero.tower_influence import POTENTIAL_NAMES, SHADOW_NAMES, check_tower_table, tower_disturbance
from modesel.aero.wind import wind_at, wind_velocity
from modesel.multibody.kinematics import PointSet
from modesel.multibody.rotations import cross

#: |V_dot_x| [m/s] under which RtAeroCp is 0 (AeroDyn_IO.f90: its denominator
#: holds V_dot_x cubed)
CP_MIN_WIND = 0.04


def aerodyn_deck(effect):
    """The AeroDyn deck of an effect's `aerodyn` option (default: the
    built-in turbine's bundled deck)."""
    path = effect.options.get("aerodyn")
    if path is None:
        from modesel.turbine.builtin import builtin_aerodyn_for
        bundled = builtin_aerodyn_for(effect.scene.turbine.source or "")
        if bundled is None:
            raise effect.error("give the AeroDyn deck: aerodyn = \"path\" (relative to the scene)", "aerodyn")
        path = str(bundled)
    if not Path(path).is_file():
        raise ModeselError("AeroDyn file not found", file=path, field=f"effects.{effect.name}.aerodyn")
    # kept while its files are unchanged (kept by path alone, a warm server's
    # commands ran the deck as it was at the server's first run)
    from modesel.turbine.aerodyn import shared_aerodyn
    deck = shared_aerodyn(path)
    deck.check_equal_blades(effect.scene.turbine.num_blades)
    return deck


def wind_of(effect, built):
    """The scene's wind field (the `wind` effect), or a user error."""
    wind = built.effect("wind")
    if wind is None:
        raise effect.error("needs a wind: add [effects.wind]")
    return wind.field


class BladeAerodynamics(Effect):
    name = "aero"
    loads = True
    kinked = True             # the polars are interpolated linearly in the angle of attack
    CHANNELS = ("RtAeroFxh", "RtAeroMxh", "RtAeroPwr", "RtAeroCp", "RtAeroCq", "RtAeroCt", "RtSpeed", "RtTSR",
                "RtVAvgxh", "RtSkew", "RtArea", "RtAeroFyh", "RtAeroFzh", "RtAeroMyh", "RtAeroMzh")
    OPTIONS = {
        "aerodyn": Option("path", None, "AeroDyn main file"),
        "skew": Option("bool", None, "Pitt-Peters skewed-wake correction"),
        "air_density": Option("number", None, "air density [kg/m^3] (default: the deck's)", positive=True),
        "pitching_moment": Option("bool", None, "sectional pitching moment Cm q c^2 (default: the deck's UseBlCm)"),
        "tower_potential": Option("choice", "none", "potential flow around the tower (AeroDyn's TwrPotent)",
                                  choices=POTENTIAL_NAMES),
        "tower_shadow": Option("choice", "none", "tower shadow downstream (AeroDyn's TwrShadow)",
                               choices=SHADOW_NAMES),
    }

    def setup(self, built):
        from modesel.aero.bem import BemOptions, BemSolver, bem_weight
        model, eq, t = built.model, built.eq, built.model.turbine
        self.bem_weight = bem_weight
        self.wind = wind_of(self, built)
        deck = aerodyn_deck(self)
        self.deck = deck
        over = {} if self.options["skew"] is None else {"skew_correction": self.options["skew"]}
        span = deck.blade.span
        # AeroDyn's nodes sit on the structural blade by their span from the root (OpenFAST
        # maps its meshes by position): a shorter AeroDyn blade leaves the outer part without
        # aerodynamic load, as in OpenFAST; a longer one would reach past the structure
        if span[-1] > t.blade.length * 1.01:
            raise self.error(f"the AeroDyn blade ({span[-1]:g} m) is longer than the structural blade "
                             f"({t.blade.length:g} m)", "aerodyn")
        solver = BemSolver.from_blade(deck.blade, span, num_blades=t.num_blades, hub_radius=t.hub_radius,
                                      precone=float(t.precone[0]),
                                      air_density=(deck.air_density if self.options["air_density"] is None
                                                   else self.options["air_density"]),
                                      options=BemOptions.from_deck(deck, **over), curve_losses=True)
        B, M = t.num_blades, len(span)
        self.bem = StationBem(solver, B)
        self.names = [f"blade{b}" for b in range(1, B + 1)]
        self.stations = []
        self.nodes = []
        self.slopes = []
        for name in self.names:
            s0, Phi, S = model.station_shapes(name, span)
            s0[:, :2] += deck.blade.reference_line()[:, :2]     # AeroDyn's nodes: the aerodynamic centres
            self.stations.append(PointSet.of_points(eq, name, s0, Phi, S))
            self.nodes.append(PointSet.of_body(eq, name))
            self.slopes.append(np.ascontiguousarray(model.station_slopes(name, span)))
        self.reference = section_reference(deck.blade.crv_angle, deck.blade.twist, model.pitch)
        self.r = np.empty((B, M))
        self.tip_ratio = np.empty((B, M))
        self.rotation = np.empty((B, M, 3))
        self.theta = np.empty((B, M))
        nodes_span = self.nodes[0].s0[:, 2]
        self.weights = np.asarray(model.weights[self.names[0]], float)
        self.elastic = np.array([st.idx for st in self.stations], dtype=np.int64).reshape(B, -1)
        line = deck.blade.reference_line()
        self.node_slopes = np.ascontiguousarray(model.station_slopes(self.names[0], nodes_span))
        self.correction = np.zeros((M, 3, 0))
        if model.blade_elastodyn_nodes:
            self.transfer = _lumped_transfer(span, nodes_span, self.weights > 0)
            structural = self.weights > 0
            body = eq.system.body(self.names[0])
            phi = np.asarray(body.shapes, float)
            augmented = _augmented_line(line, nodes_span, structural)
            self.correction = np.ascontiguousarray(_elastodyn_correction(
                augmented, nodes_span, phi, self.node_slopes, self.transfer))
            self.lumping, self.near, self.offset = _elastodyn_moment_points(augmented)
            points, interp, near = augmented
            lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
            self.augmented = (interp, near, lengths, _line_lumping(lengths) @ interp)
        else:
            self.transfer = sampled_transfer(span, nodes_span, self.weights)
            self.lumping = self.transfer
            self.near = np.arange(len(nodes_span), dtype=np.int64)
            self.offset = np.zeros((len(nodes_span), 3))
            for c in range(2):
                self.offset[:, c] = np.interp(nodes_span, span, line[:, c])
        self.transfer_rows = row_bands(self.transfer)
        self.lumping_rows = row_bands(self.lumping)
        use_cm = deck.pitching_moment if self.options["pitching_moment"] is None else self.options["pitching_moment"]
        self.cm_scale = 1.0 if use_cm else 0.0
        self.hub = eq.body_index["hub"]
        self.blades = np.array([eq.body_index[n] for n in self.names], dtype=np.int64)
        self.pitch = model.pitch
        self.pos = np.empty((B, M, 3))
        self.vel = np.empty((B, M, 3))
        self.vrel = np.empty(3)
        self.vn, self.vt, self.skew, self.psi = (np.empty((B, M)) for _ in range(4))
        self.en = np.empty((B, M, 3))
        self.et = np.empty((B, M, 3))
        self.forces = np.empty((B, len(nodes_span), 6))     # node forces [N], moments [N m]
        self.disturbance = np.zeros((B, M, 3))                # the tower's influence on the wind [m/s]
        self.tower = self._tower_influence(built, deck)

    @property
    def tower_influence(self) -> bool:
        """Whether the blades' wind has the tower's influence (module doc 2; its
        compiled loads are then `effects.compiled.loads_function(True)`)."""
        return self.tower is not None

    def _tower_influence(self, built, deck):
        """(TowerInfluence, the AeroDyn tower nodes as tower points, a buffer
        for the wind there, the influence's packed floats) of the tower_potential / tower_shadow options
        (module doc 2), or None."""
        from modesel.aero.tower_influence import TowerInfluence
        potential = POTENTIAL_NAMES.index(self.options["tower_potential"])
        shadow = SHADOW_NAMES.index(self.options["tower_shadow"])
        if potential == 0 and shadow == 0:
            return None
        table = deck.tower
        check_tower_table(table, potential, shadow, deck.source)
        elevation, _, points = aerodyn_tower_stations(self, built, table.elevation)
        diameter, cd = table.properties(elevation)
        ti = (np.zeros_like(elevation) if table.turbulence is None
              else np.interp(elevation, table.elevation, table.turbulence))
        influence = TowerInfluence(potential, shadow, diameter, cd, ti)
        return influence, points, np.empty((len(elevation), 3)), influence.packed()

    def _disturb(self, frames, q_all, qd_all, wp):
        """self.disturbance: the tower's influence at the stations (module doc 2)."""
        influence, points, wind, props = self.tower
        pos, vel = points.kinematics(frames, q_all, qd_all)
        for k in range(len(pos)):
            wind[k] = wind_velocity(wp, pos[k, 0], pos[k, 1], pos[k, 2])
        tower_disturbance(influence.potential, influence.shadow, self.pos, pos, vel, wind, props,
                          self.disturbance)

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        frames = built.frames(q_all, qd_all)
        R, vec = frames
        for b, st in enumerate(self.stations):
            st.kinematics(frames, q_all, qd_all, self.pos[b], self.vel[b])
            station_rotations(R[self.blades[b]], self.slopes[b], q_all[st.idx], self.rotation[b])
        wp = self.wind.params(t)
        if self.tower is not None:
            self._disturb(frames, q_all, qd_all, wp)
        tsr = inflow(R, vec, self.hub, self.blades, self.pos, self.vel, self.rotation, self.reference,
                     wp, self.disturbance, self.vn, self.vt, self.skew, self.psi, self.en, self.et, self.theta,
                     self.r, self.tip_ratio, self.vrel, True)
        fn, ft = self.bem(self.r, self.vn, self.vt, self.pitch, self.skew, self.psi, self.tip_ratio,
                          self.theta, self.bem_weight(tsr))
        distribute(fn, ft, self.en, self.et, *self.transfer_rows, self.forces)
        if self.correction.shape[2]:
            elastic_correction(fn, ft, self.en, self.et, R, self.blades, self.correction, self.elastic, generalized)
        node_moments(fn, ft, self.bem.buffers.out[11].reshape(fn.shape), self.cm_scale, self.en, self.et, R,
                     self.blades, *self.lumping_rows, self.near, self.offset, self.node_slopes, self.elastic,
                     self.forces, generalized)
        for b, name in enumerate(self.names):      # self.forces is overwritten at the next call
            f = node_forces.get(name)
            node_forces[name] = self.forces[b] if f is None else f + self.forces[b]
        self.last = {"q": q_all, "qd": qd_all, "v_dot_x": float(self.vrel @ R[self.hub][:, 0]), "tsr": tsr,
                     "skew": float(self.skew[0, 0]), "rmax": float(self.r.max())}

    def line_state(self) -> tuple:
        """This effect's last call's line loads and where they act, as
        `openfast_node_loads` takes them: (f_n, f_t, c_m, e_n, e_t, pos), the
        normal and tangential loads f_n, f_t [N/m] and the pitching moment c_m
        [N m/m] (B, M), their directions e_n, e_t and the AeroDyn nodes'
        positions pos [m] (B, M, 3) (buffers: overwritten at the next call)."""
        cm = self.cm_scale * self.bem.buffers.out[11].reshape(self.r.shape)
        return self.bem.buffers.f_n, self.bem.buffers.f_t, cm, self.en, self.et, self.pos

    def openfast_node_loads(self, b, node_pos, line):
        """(n, N, 6) forces [N] and moments about the nodes [N m] (inertial)
        that OpenFAST hands ElastoDyn's nodes of blade b at n times, from the
        line states `line` (`line_state()`'s arrays with a leading axis of the n
        times) and the nodes' positions `node_pos` (n, N, 3) then, on ElastoDyn's
        nodes only: the line loads and pitching moments interpolated to the
        augmented line (`_augmented_line`), lumped per element as
        ModMesh_Mapping Lump_Line2_to_Point lumps them (F_1 += h (2 f_1 + f_2) / 6,
        end moments +-(h/12) dp x (f_1 + f_2), dp the displaced element), each
        point's load moved to its nearest node with the moment of its offset.
        The section loads of the strain gauges (model/gauges.py) sum these, as
        ElastoDyn does."""
        interp, near, h, lumping = self.augmented
        fn, ft, cm, en, et, pos = (a[:, b] for a in line)
        load = fn[..., None] * en + ft[..., None] * et                              # [N/m]
        pitching = cm[..., None] * cross(et, en)                                    # [N m/m]
        f, r = interp @ load, interp @ pos
        force, moment = lumping @ load, lumping @ pitching          # lumping = L I (`_line2_lumping`)
        end = (h / 12.0)[:, None] * cross(r[:, 1:] - r[:, :-1], f[:, 1:] + f[:, :-1])
        moment[:, :-1] += end
        moment[:, 1:] -= end
        out = np.zeros(node_pos.shape[:2] + (6,))
        np.add.at(out, (slice(None), near), np.concatenate([force, moment + cross(r - node_pos[:, near], force)],
                                                           axis=-1))
        return out

    def load_points(self, built):
        """Each blade's node loads are T f of the station loads f (module doc 5)."""
        return {name: self.transfer for name in self.names}

    def compile_loads(self, built, packer, packed):
        """Pack this effect for the compiled loop (`effects.compiled._aero`):
        the same arrays `__call__` uses, and `solve_into`'s arguments; the
        blades' loads at their load points where `packed` has them (all
        blades alike), else at their nodes."""
        from modesel.model.effects.packing import AERO, point_set_ints
        B, M = self.r.shape
        N = self.forces.shape[1]
        points = [packed.load_points.get(n) for n in self.names]
        at_points = all(lp is not None for lp in points)
        rows = M if at_points else N
        s, buf = self.bem.solver, self.bem.buffers
        o = s.options
        grid, value, slope = s.polars.arrays
        o_const = packer.add([s.num_blades, s.tip_radius, s.hub_radius, s.air_density, o.skew_factor,
                              o.tolerance])
        o_elem = packer.add(buf.chord.ravel())
        T_band, T_first = self.transfer_rows
        L_band, L_first = self.lumping_rows
        o_T = packer.add(T_band)
        o_pol = packer.add(np.concatenate([grid, value.ravel(), slope.ravel()]))
        o_ref = packer.add(self.reference)
        o_slopes = packer.add(np.concatenate([np.ravel(g) for g in self.slopes]))
        static_loss = s.loss is not None
        o_loss = packer.add(np.concatenate([buf.c_tip.ravel(), buf.c_hub.ravel()])) if static_loss else 0
        ne_el = self.elastic.shape[1]
        has_corr = self.correction.shape[2] > 0
        o_corr = packer.add(self.correction) if has_corr else 0
        K = len(self.near)
        o_mom = packer.add(np.concatenate([[self.cm_scale], L_band.ravel(), self.offset.ravel(),
                                           self.node_slopes.ravel()]))
        o_pts = 0
        if at_points:
            wm, ow, Dc, Dg = moment_points(self.lumping, self.near, self.offset, self.node_slopes)
            o_pts = packer.add(np.concatenate([points[0].weights, wm, ow.ravel(), Dc.ravel(), Dg.ravel()]))
        scratch = 5 * B * M * 3 + 9 * B * M + 3 + 13 * B * M + B * rows * 6
        o_scr = packer.scratch(scratch + B * M)
        # the last B M: each element's previous BEM root (NaN: none yet), `bem._solve_phi`'s guess
        packer.set_state(o_scr + scratch, np.full(B * M, np.nan))
        o_ch = packer.scratch(len(self.CHANNELS))
        for k, name in enumerate(self.CHANNELS):
            packer.channel(name, o_ch + k)
        o_gen = packer.scratch(built.eq.n_all)        # the generalised forces, kept for held loads
        o_dist = packer.scratch(B * M * 3)            # the tower's influence at the stations (zeros without)
        # the header's last three ints: where the tower influence's ints (0: none), the
        # stations' point sets and the BEM flags start in the record
        ints = [self.hub, B, M, N, o_const, o_elem, o_T, o_pol, grid.size, value.shape[1], o_scr,
                o_ref, o_slopes, o_loss, int(static_loss), o_corr, ne_el, int(has_corr), o_mom, K, o_ch,
                T_band.shape[1], L_band.shape[1], o_gen, rows, o_pts, o_dist, 0, 0, 0]
        tower_at, stations_at, flags_at = len(ints) - 3, len(ints) - 2, len(ints) - 1
        first = [lp.first for lp in points] if at_points else [packed.node_rows(n)[0] for n in self.names]
        ints += list(self.blades) + first + list(buf.offset.ravel())
        ints += list(np.asarray(self.elastic, np.int64).ravel()) + list(self.near)
        ints += list(T_first) + list(L_first)
        ints[stations_at] = len(ints)
        for st in self.stations:
            ints += point_set_ints(packer, st)
        ints[flags_at] = len(ints)
        ints += [o.tip_loss, o.hub_loss, o.tangential_induction, o.axial_drag, o.tangential_drag,
                 o.skew_correction, o.max_iterations]
        # the points of the loads, read only for the channels (`compiled._rotor_channels`)
        for name, nodes, lp in zip(self.names, self.nodes, points):
            ints += point_set_ints(packer, PointSet.of_points(built.eq, name, lp.s0, lp.Phi, lp.S)
                                   if at_points else nodes)
        if self.tower is not None:      # (potential, shadow, m, props, scratch 9 m, tower points): `_tower`
            influence, tower_points, _, props = self.tower
            m = len(tower_points.s0)
            packer.tower_influence = True
            ints[tower_at] = len(ints)
            ints += [influence.potential, influence.shadow, m, packer.add(props),
                     packer.scratch(9 * m)] + point_set_ints(packer, tower_points)
        packer.record(AERO, ints)

    def channels(self, built):
        """AeroDyn's rotor channels (AeroDyn_IO.f90): RtAeroFxh [N] and
        RtAeroMxh [N m], the blade loads' force along and moment about the
        hub x axis (through the apex), and RtAeroFyh, RtAeroFzh [N], RtAeroMyh,
        RtAeroMzh [N m] along and about the hub's y and z axes, which turn
        with the rotor (z along blade 1; `rotor_loads`); RtAeroPwr [W] = RtAeroMxh * rotor
        speed; RtAeroCp, RtAeroCq, RtAeroCt (`rotor_power`) with V the
        disk-averaged relative wind along the hub x axis (`V_dot_x`: wind
        minus blade velocity, averaged over the stations), also RtVAvgxh
        [m/s], and RtArea = pi rmax^2 [m^2] with rmax the largest station
        radius r_local of the deflected rotor (AeroDyn's, also in the
        coefficients); RtSpeed [rpm] the hub's spin about
        its x axis; RtTSR [-] and RtSkew [deg] as the BEM used them
        (`inflow`: the tip-speed ratio of the low-TSR blend, chi_0)."""
        if not self.last:
            return {}
        frames = built.frames(self.last["q"], self.last["qd"])
        R, vec = frames
        hub = np.zeros(6)
        for b, nodes in enumerate(self.nodes):
            pos, _ = nodes.kinematics(frames, self.last["q"], self.last["qd"])
            rotor_loads(self.forces[b], pos, R[self.hub], vec[self.hub, 0], hub)
        thrust, torque = hub[0], hub[3]
        omega = float(vec[self.hub, 2] @ R[self.hub][:, 0])
        v = self.last["v_dot_x"]
        rmax = self.last["rmax"]
        power, cp, cq, ct = rotor_power(torque, thrust, omega, v, self.bem.solver.air_density, rmax)
        return {"RtAeroFxh": thrust, "RtAeroMxh": torque, "RtAeroPwr": power, "RtAeroCp": cp, "RtAeroCq": cq,
                "RtAeroCt": ct, "RtSpeed": omega * 30.0 / np.pi, "RtTSR": self.last["tsr"], "RtVAvgxh": v,
                "RtSkew": np.degrees(self.last["skew"]), "RtArea": np.pi * rmax ** 2,
                "RtAeroFyh": hub[1], "RtAeroFzh": hub[2], "RtAeroMyh": hub[4], "RtAeroMzh": hub[5]}


class StationBem:
    """`solver` on a fixed (n_blades, n_stations) element set: (f_n, f_t)
    [N/m] by `BemSolver.solve_into` into buffers allocated once (views,
    overwritten by the next call)."""

    def __init__(self, solver, n_blades):
        self.solver = solver
        self.buffers = solver.allocate((n_blades, solver.chord.size))

    def __call__(self, r, vn, vt, pitch, skew, psi, tip_ratio=None, section_angle=None, weight=1.0):
        self.solver.solve_into(self.buffers, r, vn, vt, pitch, skew, psi, tip_ratio, section_angle, weight)
        return self.buffers.f_n, self.buffers.f_t


@njit(cache=True)
def rotor_loads(forces, pos, R_hub, apex, out):
    """Adds to out[0:3] the force and to out[3:6] the moment about the apex
    of node forces (columns 0-2) and node moments (3-5), both in the hub
    frame (columns of R_hub: x_s along the shaft, thrust and torque; y and
    z turning with the rotor, z along blade 1's undeflected axis: AeroDyn's
    hub orientation, RtAeroF*h and RtAeroM*h)."""
    for i in range(forces.shape[0]):
        f = forces[i]
        d0, d1, d2 = pos[i, 0] - apex[0], pos[i, 1] - apex[1], pos[i, 2] - apex[2]
        m0, m1, m2 = d1 * f[2] - d2 * f[1], d2 * f[0] - d0 * f[2], d0 * f[1] - d1 * f[0]
        m0, m1, m2 = m0 + f[3], m1 + f[4], m2 + f[5]
        for k in range(3):
            out[k] += f[0] * R_hub[0, k] + f[1] * R_hub[1, k] + f[2] * R_hub[2, k]
            out[3 + k] += m0 * R_hub[0, k] + m1 * R_hub[1, k] + m2 * R_hub[2, k]


@njit(cache=True)
def rotor_power(torque, thrust, omega, v, rho, rmax):
    """(RtAeroPwr [W], RtAeroCp, RtAeroCq, RtAeroCt [-]) of the rotor torque
    [N m] and thrust [N] at rotor speed omega [rad/s], with v [m/s] the
    disk-averaged relative wind along the hub x axis, air density rho
    [kg/m^3] and RtArea = pi rmax^2 (AeroDyn_IO.f90: q = 1/2 rho RtArea v^2,
    Cp = P / (q v), Cq = Q / (q rmax), Ct = T / q; all 0 for |v| < CP_MIN_WIND)."""
    power = torque * omega
    if abs(v) < CP_MIN_WIND:
        return power, 0.0, 0.0, 0.0
    q = 0.5 * rho * np.pi * rmax * rmax * v * v
    return power, power / (q * v), torque / (q * rmax), thrust / q


def sampled_transfer(stations, at, weights):
    """(nodes, stations) matrix T: node force = sum_a T[i, a] f_a with f
    interpolated linearly to the node and times its weight (module doc 5);
    none on a node beyond the stations (a blade longer than AeroDyn's, whose
    outer part has no aerodynamic load, as in OpenFAST)."""
    lo, frac = _linear_weights(stations, at)
    T = np.zeros((len(at), len(stations)))
    rows = np.arange(len(at))
    inside = (np.asarray(at) >= stations[0] - 1e-9) & (np.asarray(at) <= stations[-1] + 1e-9)
    T[rows, lo] += (1.0 - frac) * weights * inside
    T[rows, lo + 1] += frac * weights * inside
    return T


def cell_transfer(stations, at, weights):
    """(nodes, stations) matrix T: node force = sum_a T[i, a] f_a, the line
    load, linear between the stations and none beyond them, integrated over
    each node's cell [at - w/2, at + w/2] (ElastoDyn's nodes: the midpoints
    of elements of length DHNodes = w). Where the stations cover the nodes'
    cells this is `sampled_transfer` with the exact integral in place of the
    midpoint rule; where they end inside a cell, only the covered part
    counts, so the total force is the line load's. OpenFAST's mapping sends
    each lumped piece of AeroDyn's line to the nearest ElastoDyn node, i.e.
    to the node whose cell it lies in (tower drag, effects/tower_drag.py)."""
    stations = np.asarray(stations, float)
    at, weights = np.asarray(at, float), np.asarray(weights, float)
    T = np.zeros((len(at), len(stations)))
    for i, (z, w) in enumerate(zip(at, weights)):
        lo, hi = max(z - 0.5 * w, stations[0]), min(z + 0.5 * w, stations[-1])
        for j in range(len(stations) - 1):
            a, b = stations[j], stations[j + 1]
            u, v = max(lo, a), min(hi, b)
            if v <= u:
                continue
            h = b - a
            T[i, j] += ((b - u) ** 2 - (b - v) ** 2) / (2.0 * h)
            T[i, j + 1] += ((v - a) ** 2 - (u - a) ** 2) / (2.0 * h)
    return T


def _lumped_transfer(stations, at, structural):
    """(nodes, stations) matrix T of the lumped transfer (module doc 5):
    L (stations, stations) lumps the piecewise-linear line load to point
    loads, F_a = sum over the two adjacent elements of h (2 f_a + f_b) / 6;
    W (nodes, stations) is the transpose of the linear interpolation of the
    `structural` nodes' positions to the stations (end elements extrapolated),
    so sum_i W[i, a] = 1 and sum_i W[i, a] z_i = z_a."""
    stations = np.asarray(stations, float)
    Lmp = _line2_lumping(stations)
    idx = np.flatnonzero(structural)
    z = np.asarray(at, float)[idx]
    W = np.zeros((len(at), len(stations)))
    if len(idx) == 1:
        W[idx[0], :] = 1.0
        return W @ Lmp
    lo = np.clip(np.searchsorted(z, stations, side="right") - 1, 0, len(z) - 2)
    a = (stations - z[lo]) / (z[lo + 1] - z[lo])
    cols = np.arange(len(stations))
    W[idx[lo], cols] += 1.0 - a
    W[idx[lo + 1], cols] += a
    return W @ Lmp


def _line_lumping(lengths):
    """`_line2_lumping` of a line of elements of `lengths` [m]."""
    return _line2_lumping(np.concatenate([[0.0], np.cumsum(lengths)]))


def _line2_lumping(span):
    """(M, M) matrix L of ModMesh's lumping of a line load, linear between
    the stations `span`, to point loads at the stations: F_a = sum_b L[a, b]
    f_b, over the two adjacent elements h (2 f_a + f_b) / 6."""
    h = np.diff(np.asarray(span, float))
    Lmp = np.zeros((len(h) + 1, len(h) + 1))
    for k, hk in enumerate(h):
        Lmp[k, k] += hk / 3.0
        Lmp[k, k + 1] += hk / 6.0
        Lmp[k + 1, k + 1] += hk / 3.0
        Lmp[k + 1, k] += hk / 6.0
    return Lmp


def _nearest_nodes(points, nodes, structural):
    """(P,) the structural node (index into `nodes`, span [m] on the blade
    axis) nearest to each of `points` (P, 3), as OpenFAST's point-to-point
    mapping pairs them."""
    idx = np.flatnonzero(structural)
    node_pos = np.zeros((len(idx), 3))
    node_pos[:, 2] = np.asarray(nodes, float)[idx]
    return idx[np.argmin(np.linalg.norm(np.asarray(points, float)[:, None, :] - node_pos[None, :, :], axis=2),
                         axis=1)].astype(np.int64)


#: ModMesh's shortest element of an augmented line2 mesh [m]
_MIN_ELEMENT = 1.0e-3


def _augmented_line(line, nodes, structural):
    """OpenFAST's augmented source mesh of a line2-to-point load mapping
    (ModMesh_Mapping Create_Augmented_Ln2_Src_Mesh): every element of the
    AeroDyn line (M, 3) is split where a structural node (0, 0, z_n)
    projects inside it, so the line load is lumped on the union of the
    stations and the nodes' projections. Returns (points (P, 3), I (P, M):
    the linear interpolation of station values to the points, near (P,):
    each point's nearest structural node)."""
    line = np.asarray(line, float)
    z = np.asarray(nodes, float)[np.flatnonzero(structural)]
    cuts = [[] for _ in range(len(line) - 1)]
    for zn in z:
        p = np.array([0.0, 0.0, zn])
        for k in range(len(line) - 1):
            e = line[k + 1] - line[k]
            xi = float((p - line[k]) @ e / (e @ e))
            if 1e-6 < xi < 1.0 - 1e-6:
                cuts[k].append(xi)
    rows, points = [], []
    for k in range(len(line) - 1):
        length = np.linalg.norm(line[k + 1] - line[k])
        kept = [0.0]
        for xi in sorted(cuts[k]):
            if (xi - kept[-1]) * length >= _MIN_ELEMENT and (1.0 - xi) * length >= _MIN_ELEMENT:
                kept.append(xi)
        for xi in kept:
            w = np.zeros(len(line))
            w[k], w[k + 1] = 1.0 - xi, xi
            rows.append(w)
            points.append((1.0 - xi) * line[k] + xi * line[k + 1])
    w = np.zeros(len(line))
    w[-1] = 1.0
    rows.append(w)
    points.append(line[-1])
    points = np.array(points)
    return points, np.array(rows), _nearest_nodes(points, nodes, structural)


def _elastodyn_moment_points(augmented):
    """(L, near, offset) of `node_moments` for ElastoDyn's nodes: the line
    loads lumped to the points of OpenFAST's augmented line `augmented`
    (`_augmented_line`'s (points, I, near); `_line2_lumping`; L (P, M) per unit station load),
    each point's load carried to its nearest structural node, offset (P, 3)
    = the point's (x, y, 0): the part of its offset from that node whose
    moment the node forces lack (the spanwise part is carried by the node
    forces' rigid-exact transfer and `_elastodyn_correction`)."""
    points, I, near = augmented
    offset = np.zeros_like(points)
    offset[:, :2] = points[:, :2]
    return _line2_lumping(points[:, 2]) @ I, near, offset


def _elastodyn_correction(augmented, nodes, phi, slopes, T):
    """(M, 3, ne) matrix D: the generalised forces of a blade's elastic
    coordinates as ElastoDyn receives them from AeroDyn, minus those of the
    node forces T f (`_lumped_transfer`), per unit line load at each station:
    Q_j = sum_b f_b . D[b, :, j] (f in the pitched blade frame).

    OpenFAST maps AeroDyn's line2 loads to ElastoDyn's point mesh
    (ModMesh_Mapping Transfer_Line2_to_Point): the line, split at the
    structural nodes' projections (`_augmented_line`), carries the line load
    interpolated linearly; it is lumped to point forces F_p (hat functions)
    and, per element of length h with end loads f_1, f_2, end moments
    +-(h^2/12) z x (f_1 + f_2); each point load goes to the *nearest*
    structural node n with the moment of its offset, (r_p - r_n) x F_p.
    ElastoDyn applies a node force through the node's displacement shape
    and a node moment through its rotation (the slopes: a moment M does the
    work M . (z x s_j)). augmented: `_augmented_line`'s (points, I, near) of
    the stations' line in the blade frame and the nodes ElastoDyn has (not a
    tip mass); nodes (N,): span of the body nodes; phi (N, 3, ne), slopes
    (N, 3, ne): their shapes."""
    points, I, near = augmented
    dz = points[:, 2] - np.asarray(nodes, float)[near]
    # rotation of node n per unit coordinate: theta = z x s, so (dz z x F) . theta = dz F . s
    virtual = phi[near] + dz[:, None, None] * slopes[near]                  # (P, 3, ne)
    h = np.diff(points[:, 2])
    LI = _line2_lumping(points[:, 2]) @ I
    D = np.einsum("pa,pij->aij", LI, virtual) - np.einsum("ib,ikj->bkj", T, phi)
    for k, hk in enumerate(h):     # element end moments: (h^2/12) (f_1 + f_2) . (s(n_1) - s(n_2))
        ds = (hk * hk / 12.0) * (slopes[near[k]] - slopes[near[k + 1]])
        D += (I[k] + I[k + 1])[:, None, None] * ds[None]
    return D


@njit(cache=True)
def elastic_correction(fn, ft, en, et, R, blades, D, elastic, generalized):
    """generalized[elastic[b, j]] += sum_a f_a . D[a, :, j], f_a = f_n,a e_n,a
    + f_t,a e_t,a turned into blade b's frame (`_elastodyn_correction`)."""
    for b in range(blades.shape[0]):
        Rb = R[blades[b]]
        for a in range(D.shape[0]):
            g0 = fn[b, a] * en[b, a, 0] + ft[b, a] * et[b, a, 0]
            g1 = fn[b, a] * en[b, a, 1] + ft[b, a] * et[b, a, 1]
            g2 = fn[b, a] * en[b, a, 2] + ft[b, a] * et[b, a, 2]
            f0 = Rb[0, 0] * g0 + Rb[1, 0] * g1 + Rb[2, 0] * g2
            f1 = Rb[0, 1] * g0 + Rb[1, 1] * g1 + Rb[2, 1] * g2
            f2 = Rb[0, 2] * g0 + Rb[1, 2] * g1 + Rb[2, 2] * g2
            for j in range(D.shape[2]):
                generalized[elastic[b, j]] += f0 * D[a, 0, j] + f1 * D[a, 1, j] + f2 * D[a, 2, j]


@njit(cache=True)
def node_moments(fn, ft, fm, cm_scale, en, et, R, blades, L, first, near, offset, slopes, elastic, forces,
                 generalized):
    """Node moments of the blade loads (module doc, step 5): the line loads
    f_a = f_n,a e_n,a + f_t,a e_t,a [N/m] and the pitching moments cm_scale
    fm_a e_z,a [N m/m] (e_z = e_t x e_n, the annulus z axis of the deflected
    section, AeroDyn's BEM_Mod 1) lumped to K points, F_p = sum_a L_pa f_a
    and M_p = sum_a L_pa m_a (L in banded rows, `row_bands`: L_pa =
    L[p, a - first[p]]), and with the moment of the point's offset from the
    blade axis, d_p x F_p (d_p = R_blade offset[p]), put on node
    near[p] as forces[b, near[p], 3:6] (the engine applies a node moment
    through the body's angular velocity: all rigid coordinates). The blade's
    elastic coordinates j get its work through ElastoDyn's partial angular
    velocity of the node (ElastoDyn.f90 PAngVelEM), -s_y j_1 + s_x j_2 with
    s the mode's slope at the node (slopes (N, 3, ne)) and j_1, j_2 the
    axes of the pitched blade frame (not the deflected section's)."""
    B, M = fn.shape[0], fn.shape[1]
    ne = elastic.shape[1]
    g = np.empty((M, 3))                  # f_a
    z = np.empty((M, 3))                  # e_t,a x e_n,a
    acc = np.empty(ne)                    # the blade's generalized forces, summed in node order
    for b in range(B):
        Rb = R[blades[b]]
        _line_loads(fn, ft, en, et, b, g)
        for a in range(M):
            n0, n1, n2 = en[b, a, 0], en[b, a, 1], en[b, a, 2]
            t0, t1, t2 = et[b, a, 0], et[b, a, 1], et[b, a, 2]
            z[a, 0] = t1 * n2 - t2 * n1
            z[a, 1] = t2 * n0 - t0 * n2
            z[a, 2] = t0 * n1 - t1 * n0
        for j in range(ne):
            acc[j] = generalized[elastic[b, j]]
        for i in range(forces.shape[1]):
            forces[b, i, 3] = 0.0
            forces[b, i, 4] = 0.0
            forces[b, i, 5] = 0.0
        for p in range(L.shape[0]):
            F0 = F1 = F2 = M0 = M1 = M2 = 0.0
            for k in range(L.shape[1]):
                w = L[p, k]
                if w == 0.0:
                    continue
                a = first[p] + k
                F0 += w * g[a, 0]
                F1 += w * g[a, 1]
                F2 += w * g[a, 2]
                m = w * cm_scale * fm[b, a]
                M0 += m * z[a, 0]
                M1 += m * z[a, 1]
                M2 += m * z[a, 2]
            d0 = Rb[0, 0] * offset[p, 0] + Rb[0, 1] * offset[p, 1] + Rb[0, 2] * offset[p, 2]
            d1 = Rb[1, 0] * offset[p, 0] + Rb[1, 1] * offset[p, 1] + Rb[1, 2] * offset[p, 2]
            d2 = Rb[2, 0] * offset[p, 0] + Rb[2, 1] * offset[p, 1] + Rb[2, 2] * offset[p, 2]
            M0 += d1 * F2 - d2 * F1
            M1 += d2 * F0 - d0 * F2
            M2 += d0 * F1 - d1 * F0
            n = near[p]
            forces[b, n, 3] += M0
            forces[b, n, 4] += M1
            forces[b, n, 5] += M2
            if ne == 0:
                continue
            l0 = Rb[0, 0] * M0 + Rb[1, 0] * M1 + Rb[2, 0] * M2
            l1 = Rb[0, 1] * M0 + Rb[1, 1] * M1 + Rb[2, 1] * M2
            for j in range(ne):
                acc[j] += -slopes[n, 1, j] * l0 + slopes[n, 0, j] * l1
        for j in range(ne):
            generalized[elastic[b, j]] = acc[j]


def moment_points(L, near, offset, slopes):
    """(wm (M,), ow (M, 3), Dc (M, ne, 3), Dg (M, ne, 3)) of `point_loads`:
    `node_moments`' lumping L (K, M) summed per station a over the moment
    points p (offsets o_p (K, 3), near (K,) their nodes, slopes (N, 3, ne)
    the modes' slopes s at the nodes): wm_a = sum_p L_pa, ow_a = sum_p L_pa
    o_p, and the coefficients of the blade's elastic generalised force
    sum_k Dc[a, j, k] c_k + Dg[a, j, k] f_k of the station's moment c and
    line load f in the blade frame: sum_p L_pa (-s_y l_0 + s_x l_1) of the
    point's moment l = c + o_p x f, s = slopes[near[p]]."""
    L, o = np.asarray(L, float), np.asarray(offset, float)
    sx, sy = slopes[near, 0, :], slopes[near, 1, :]                     # (K, ne)
    Dc = np.zeros((L.shape[1], sx.shape[1], 3))
    Dg = np.zeros_like(Dc)
    Dc[:, :, 0], Dc[:, :, 1] = -L.T @ sy, L.T @ sx
    Dg[:, :, 0] = L.T @ (sx * o[:, 2:3])
    Dg[:, :, 1] = L.T @ (sy * o[:, 2:3])
    Dg[:, :, 2] = -L.T @ (sy * o[:, 1:2] + sx * o[:, 0:1])
    return L.sum(axis=0), L.T @ o, Dc, Dg


@njit(cache=True)
def point_loads(fn, ft, fm, cm_scale, en, et, R, blades, w, wm, ow, Dc, Dg, elastic, loads, generalized):
    """The blade loads of `distribute` and `node_moments` at one load point
    per station (`packing.LoadPoints`, module doc 5): loads[b, a] = [w_a f_a,
    wm_a c_a + (R_b ow_a) x f_a] with f_a the line load and c_a = cm_scale
    fm_a e_z,a the pitching moment per unit length (`moment_points`: wm, ow,
    Dc, Dg), and the blade's elastic generalised force of the node moments,
    sum_a Dc_a (R_b^T c_a) + Dg_a (R_b^T f_a), added to `generalized` as
    `node_moments` adds it. The same loads as the node loads of those two
    functions, summed per station (the sums the kernel forms are linear in
    them)."""
    B, M = fn.shape[0], fn.shape[1]
    ne = elastic.shape[1]
    g = np.empty((M, 3))
    acc = np.empty(ne)
    for b in range(B):
        Rb = R[blades[b]]
        _line_loads(fn, ft, en, et, b, g)
        for j in range(ne):
            acc[j] = generalized[elastic[b, j]]
        for a in range(M):
            n0, n1, n2 = en[b, a, 0], en[b, a, 1], en[b, a, 2]
            t0, t1, t2 = et[b, a, 0], et[b, a, 1], et[b, a, 2]
            m = cm_scale * fm[b, a]
            c0, c1, c2 = m * (t1 * n2 - t2 * n1), m * (t2 * n0 - t0 * n2), m * (t0 * n1 - t1 * n0)
            d0 = Rb[0, 0] * ow[a, 0] + Rb[0, 1] * ow[a, 1] + Rb[0, 2] * ow[a, 2]
            d1 = Rb[1, 0] * ow[a, 0] + Rb[1, 1] * ow[a, 1] + Rb[1, 2] * ow[a, 2]
            d2 = Rb[2, 0] * ow[a, 0] + Rb[2, 1] * ow[a, 1] + Rb[2, 2] * ow[a, 2]
            f0, f1, f2 = g[a, 0], g[a, 1], g[a, 2]
            loads[b, a, 0] = w[a] * f0
            loads[b, a, 1] = w[a] * f1
            loads[b, a, 2] = w[a] * f2
            loads[b, a, 3] = wm[a] * c0 + d1 * f2 - d2 * f1
            loads[b, a, 4] = wm[a] * c1 + d2 * f0 - d0 * f2
            loads[b, a, 5] = wm[a] * c2 + d0 * f1 - d1 * f0
            if ne == 0:
                continue
            cb0 = Rb[0, 0] * c0 + Rb[1, 0] * c1 + Rb[2, 0] * c2
            cb1 = Rb[0, 1] * c0 + Rb[1, 1] * c1 + Rb[2, 1] * c2
            cb2 = Rb[0, 2] * c0 + Rb[1, 2] * c1 + Rb[2, 2] * c2
            gb0 = Rb[0, 0] * f0 + Rb[1, 0] * f1 + Rb[2, 0] * f2
            gb1 = Rb[0, 1] * f0 + Rb[1, 1] * f1 + Rb[2, 1] * f2
            gb2 = Rb[0, 2] * f0 + Rb[1, 2] * f1 + Rb[2, 2] * f2
            for j in range(ne):
                acc[j] += (Dc[a, j, 0] * cb0 + Dc[a, j, 1] * cb1 + Dc[a, j, 2] * cb2
                           + Dg[a, j, 0] * gb0 + Dg[a, j, 1] * gb1 + Dg[a, j, 2] * gb2)
        for j in range(ne):
            generalized[elastic[b, j]] = acc[j]


def _linear_weights(stations, at):
    """Index lo and fraction so that f(at) = (1-frac) f[lo] + frac f[lo+1]
    (linear interpolation between stations, ends held)."""
    at = np.clip(at, stations[0], stations[-1])
    lo = np.clip(np.searchsorted(stations, at, side="right") - 1, 0, len(stations) - 2)
    frac = (at - stations[lo]) / (stations[lo + 1] - stations[lo])
    return lo.astype(np.int64), frac


def section_reference(crv_angle, twist, pitch):
    """(M, 3, 3) AeroDyn's reference orientation of each blade node relative to
    the blade's coned (unpitched) root frame, as a change of basis (rows: the
    section axes): EulerConstruct(0, BlCrvAng, -BlTwist) EulerConstruct(0, 0,
    -pitch), EulerConstruct(t) = R_z(t_z) R_y(t_y) R_x(t_x) with
    R_z(t) = [[cos t, sin t, 0], [-sin t, cos t, 0], [0, 0, 1]] and
    R_y(t) = [[cos t, 0, -sin t], [0, 1, 0], [sin t, 0, cos t]]."""
    def rz(t):
        c, s_ = np.cos(t), np.sin(t)
        return np.array([[c, s_, 0.0], [-s_, c, 0.0], [0.0, 0.0, 1.0]])

    def ry(t):
        c, s_ = np.cos(t), np.sin(t)
        return np.array([[c, 0.0, -s_], [0.0, 1.0, 0.0], [s_, 0.0, c]])

    crv = np.broadcast_to(np.asarray(crv_angle, float), np.shape(twist))
    return np.ascontiguousarray(np.stack([rz(-tw) @ ry(cv) @ rz(-float(pitch))
                                          for cv, tw in zip(crv, np.asarray(twist, float))]))


@njit(cache=True)
def station_rotations(R_blade, G, qe, out):
    """ElastoDyn's small-rotation vector (M, 3), inertial, of the deflected
    blade's section at each station: R_blade (-g_y, g_x, 0), g = G q_e the
    slope of the elastic displacement in the pitched blade frame (G (M, 3,
    ne) per unit coordinate, `TurbineModel.station_slopes`); its components
    are ElastoDyn's ThetaIP and ThetaOoP (SetCoordSy)."""
    for k in range(G.shape[0]):
        g0 = 0.0
        g1 = 0.0
        for l in range(qe.shape[0]):
            g0 += G[k, 0, l] * qe[l]
            g1 += G[k, 1, l] * qe[l]
        for i in range(3):
            out[k, i] = -R_blade[i, 0] * g1 + R_blade[i, 1] * g0


#: NWTC EqualRealNos8's tolerance about zero (50 machine epsilons): AeroDyn's TSR is 0 for a
#: disk-averaged wind along the shaft this small (`inflow`)
ZERO_TOLERANCE = 50.0 * 2.220446049250313e-16


@njit(cache=True)
def inflow(R, vec, hub, blades, pos, vel, rotation, A, wp, dist, vn, vt, skew, psi, en, et, theta, r_local,
           tip_ratio, vrel, field=None):
    """Element inflow (module doc, steps 2-3) for all blades and stations;
    wp = `Wind.params(t)`, dist (B, M, 3) [m/s] the tower's influence added
    to the wind at each station (`aero.tower_influence`; zeros without it:
    AeroDyn's DisturbedInflow, which the disk average takes too), rotation (B, M, 3) the sections' small-rotation
    vectors (`station_rotations`), A (M, 3, 3) their reference orientations
    (`section_reference`). Fills vn, vt, en, et (B, M, 3: the annulus normal
    and the direction of rotation of each station), theta (B, M: the
    section's pitch + twist, aerodynamic and elastic, as AeroDyn extracts it),
    r_local and tip_ratio (B, M), skew and psi (B, M), and vrel (3,) the
    disk-averaged relative wind (wind minus station velocity, averaged
    over all stations). Returns the rotor's tip-speed ratio as AeroDyn
    forms it for `bem.bem_weight` (AeroDyn.f90 SetInputsForBEMT): the hub's
    angular velocity about the shaft times the largest r_local of all blades
    over vrel along the shaft (0 where that wind is zero). field None: the
    wind is uniform (`aero.wind.wind_at`; True: a full field may be packed in wp)."""
    xs = R[hub, :, 0]
    apex = vec[hub, 0]
    vrel[0] = 0.0
    vrel[1] = 0.0
    vrel[2] = 0.0
    r_rotor = 0.0
    for b in range(blades.shape[0]):
        zb = R[blades[b], :, 2]
        c = xs[0] * zb[0] + xs[1] * zb[1] + xs[2] * zb[2]
        n0, n1, n2 = xs[0] - c * zb[0], xs[1] - c * zb[1], xs[2] - c * zb[2]
        nn = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        n0, n1, n2 = n0 / nn, n1 / nn, n2 / nn
        t0, t1, t2 = n1 * zb[2] - n2 * zb[1], n2 * zb[0] - n0 * zb[2], n0 * zb[1] - n1 * zb[0]
        rmax = 0.0
        for k in range(pos.shape[1]):
            # the section in the coned root frame (x: e_c, y: z_b x e_c = -e_t,
            # z: z_b): ElastoDyn's SmllRotTrans of the rotation vector (first
            # column), times the reference orientation A; AeroDyn's
            # EulerExtract gives the out-of-plane angle (sin = M31, turning the
            # annulus normal about the coned y axis) and the twist
            # atan2(M21, M11) (NoSweepPitchTwist)
            ra, rb, rc = rotation[b, k, 0], rotation[b, k, 1], rotation[b, k, 2]
            x1 = ra * n0 + rb * n1 + rc * n2
            x2 = -(ra * t0 + rb * t1 + rc * t2)
            x3 = ra * zb[0] + rb * zb[1] + rc * zb[2]
            w = np.sqrt(max(0.0, 1.0 - 0.25 * (x1 * x1 + x2 * x2 + x3 * x3)))
            c1, c2, c3 = 1.0 - 0.5 * (x2 * x2 + x3 * x3), 0.5 * x1 * x2 - x3 * w, 0.5 * x1 * x3 + x2 * w
            m11 = A[k, 0, 0] * c1 + A[k, 0, 1] * c2 + A[k, 0, 2] * c3
            m21 = A[k, 1, 0] * c1 + A[k, 1, 1] * c2 + A[k, 1, 2] * c3
            s_ = min(1.0, max(-1.0, A[k, 2, 0] * c1 + A[k, 2, 1] * c2 + A[k, 2, 2] * c3))
            theta[b, k] = np.arctan2(m21, m11)
            c_ = np.sqrt(1.0 - s_ * s_)
            a0, a1, a2 = c_ * n0 - s_ * zb[0], c_ * n1 - s_ * zb[1], c_ * n2 - s_ * zb[2]
            en[b, k, 0], en[b, k, 1], en[b, k, 2] = a0, a1, a2
            et[b, k, 0], et[b, k, 1], et[b, k, 2] = t0, t1, t2
            uk0, uk1, uk2 = wind_at(wp, pos[b, k, 0], pos[b, k, 1], pos[b, k, 2], field)
            v0 = uk0 + dist[b, k, 0] - vel[b, k, 0]
            v1 = uk1 + dist[b, k, 1] - vel[b, k, 1]
            v2 = uk2 + dist[b, k, 2] - vel[b, k, 2]
            vrel[0] += v0
            vrel[1] += v1
            vrel[2] += v2
            vn[b, k] = v0 * a0 + v1 * a1 + v2 * a2
            vt[b, k] = -(v0 * t0 + v1 * t1 + v2 * t2)
            # local radius: the station projected on the rotor plane
            p0, p1, p2 = pos[b, k, 0] - apex[0], pos[b, k, 1] - apex[1], pos[b, k, 2] - apex[2]
            pa = p0 * xs[0] + p1 * xs[1] + p2 * xs[2]
            p0, p1, p2 = p0 - pa * xs[0], p1 - pa * xs[1], p2 - pa * xs[2]
            r_local[b, k] = np.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
            rmax = max(rmax, r_local[b, k])
        for k in range(pos.shape[1]):
            tip_ratio[b, k] = r_local[b, k] / rmax
        r_rotor = max(r_rotor, rmax)
    n = blades.shape[0] * pos.shape[1]
    vrel[0] /= n
    vrel[1] /= n
    vrel[2] /= n
    # skew (Pitt-Peters) from the disk-averaged relative wind (AeroDyn DiskAvgValues)
    wa = vrel[0] * xs[0] + vrel[1] * xs[1] + vrel[2] * xs[2]
    q0, q1, q2 = vrel[0] - wa * xs[0], vrel[1] - wa * xs[1], vrel[2] - wa * xs[2]
    wp_ = np.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    chi0 = np.arctan2(wp_, wa)
    for b in range(blades.shape[0]):
        zb = R[blades[b], :, 2]
        c = xs[0] * zb[0] + xs[1] * zb[1] + xs[2] * zb[2]
        r0, r1, r2 = zb[0] - c * xs[0], zb[1] - c * xs[1], zb[2] - c * xs[2]
        rr = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        psi_b = 0.0
        if wp_ > 0.0:
            cp = (r0 * q0 + r1 * q1 + r2 * q2) / (rr * wp_)
            psi_b = np.arccos(min(1.0, max(-1.0, cp)))
        for k in range(pos.shape[1]):
            skew[b, k] = chi0
            psi[b, k] = psi_b
    if abs(wa) <= ZERO_TOLERANCE:
        return 0.0
    w_hub = vec[hub, 2]
    return (w_hub[0] * xs[0] + w_hub[1] * xs[1] + w_hub[2] * xs[2]) * r_rotor / wa


@njit(cache=True)
def distribute(fn, ft, en, et, T, first, out):
    """Node forces out[b, i] = sum_a T_ia (f_n,a e_n,a + f_t,a e_t,a) from
    the loads per unit length at the stations (module doc, step 5; en, et
    (B, M, 3) per station); T in banded rows (`row_bands`): T_ia =
    T[i, a - first[i]]."""
    g = np.empty((fn.shape[1], 3))        # f_a, once per station
    for b in range(out.shape[0]):
        _line_loads(fn, ft, en, et, b, g)
        for i in range(out.shape[1]):
            f0 = first[i]
            v0 = v1 = v2 = 0.0
            for k in range(T.shape[1]):
                w = T[i, k]
                a = f0 + k
                v0 += w * g[a, 0]
                v1 += w * g[a, 1]
                v2 += w * g[a, 2]
            out[b, i, 0] = v0
            out[b, i, 1] = v1
            out[b, i, 2] = v2


@njit(cache=True, inline="always")
def _line_loads(fn, ft, en, et, b, g):
    """g[a] = f_n,a e_n,a + f_t,a e_t,a [N/m]: blade b's line load at each station."""
    for a in range(fn.shape[1]):
        for c in range(3):
            g[a, c] = fn[b, a] * en[b, a, c] + ft[b, a] * et[b, a, c]


def row_bands(W):
    """The rows of a (rows, cols) matrix W as bands: (values (rows, width),
    first (rows,) int64) with W[i, first[i] + k] = values[i, k] and zero
    outside, width the widest band of non-zeros of any row (at least 1).
    The transfer and lumping matrices have a few non-zeros per row (linear
    interpolation, line lumping), so `distribute` and `node_moments` cost
    the band instead of every station."""
    W = np.asarray(W, float)
    rows, cols = W.shape
    nz = W != 0.0
    lo = np.where(nz.any(axis=1), nz.argmax(axis=1), 0)
    hi = np.where(nz.any(axis=1), cols - 1 - nz[:, ::-1].argmax(axis=1), 0)
    width = max(int((hi - lo).max(initial=0)) + 1, 1)
    first = np.minimum(lo, cols - width).astype(np.int64)
    values = np.zeros((rows, width))
    for i in range(rows):
        values[i] = W[i, first[i]:first[i] + width]
    return values, first


def aerodyn_tower_stations(effect, built, table):
    """(elevations [m], body-frame heights [m], tower points `PointSet`) of
    AeroDyn's tower nodes on the tower: the table's elevations `table` [m],
    cut at the tower's base and top where the table reaches beyond them
    (effects/tower_drag.py); heights at rest from the nodes' (the undeflected
    tower is straight); the points with the tower's shapes there. The tower
    drag and the aero effect's tower influence (`_tower_influence`) take them."""
    q, qd = _rest(built)
    # the numpy reference (`KaneEquations.node_kinematics`): the compiled frames would
    # compile here, before the first run's parallel compile (`simulation.first_run`)
    eq = built.eq
    z_rest = eq.node_kinematics("tower", eq.kinematics(q, qd)[eq.body_index["tower"]], q, qd)[0][:, 2]
    local = PointSet.of_body(eq, "tower").s0[:, 2]
    slope, base = np.polyfit(local, z_rest, 1) if len(local) > 1 else (1.0, z_rest[0] - local[0])
    tower = built.model.turbine.tower
    ends = np.array([tower.root_offset, tower.root_offset + tower.length])
    table = np.asarray(table, float)
    rows = (table - base) / slope
    tol = 1e-6 * tower.length
    lo, hi = max(ends[0], rows.min()), min(ends[1], rows.max())
    if hi - lo <= tol:
        raise effect.error(f"the AeroDyn tower table (TwrElev {table.min():g} to {table.max():g} m) does not "
                           f"reach the tower (base {base + slope * ends[0]:g} m, top {base + slope * ends[1]:g} m "
                           "above the ground)", "aerodyn")
    inside = rows[(rows > lo + tol) & (rows < hi - tol)]
    local = np.concatenate([[lo], inside, [hi]])
    s0, Phi, S = built.model.station_shapes("tower", local - tower.root_offset)
    return base + slope * local, local, PointSet.of_points(eq, "tower", s0, Phi, S)


def _rest(built):
    """All coordinates and rates of the undeflected turbine at rest."""
    n = built.eq.n_all
    return built.eq.fixed_values.copy(), np.zeros(n)


EFFECT = BladeAerodynamics
