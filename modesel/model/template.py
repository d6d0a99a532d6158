"""Turbine template: builds the body tree of a horizontal-axis wind turbine
(first paper Fig. 4 and 7; second paper section 2, eq. 11-31) from a
`Turbine`, a `ModeSet` and the DOFs a scene frees.

Bodies (parents first): [platform] -> tower (flexible: fore-aft, side-side,
torsion modes; eq. 2-10, 37-39) -> nacelle (carried by the tower-top
elastic translation, axial shortening and rotation, eq. 11-16) -> hub
(shaft tilt, overhang, rotor azimuth GeAz + DrTr, eq. 17, 21-25) ->
blades 1..3 (flexible: flap, edge; precone and collective pitch, eq. 26-36,
40-41), the generator (azimuth GBRatio * GeAz about the shaft, eq. 18, 20)
and, with the two-spring drivetrain, the gearbox.

Drivetrain (the scene's `drivetrain` effect chooses):
- "elastodyn": ElastoDyn's single torsional spring/damper on DrTr between
  the rotor (angle GeAz + DrTr) and the generator (GeAz, LSS side).
- "two_spring": the second paper's low- and high-speed shafts (eq. 17-20,
  19, 47): the rotor (GeAz + DrTr), a rigid gearbox whose LSS-side angle is
  theta_1 = GeAz + HSSTw (theta_2 = N_g theta_1 on its HSS side) and the
  generator (N_g GeAz). The LSS twists by DrTr - HSSTw, the HSS by
  N_g HSSTw. The extra DOF is HSSTw; it needs a gearbox inertia (the paper's
  massless gearbox makes theta_1 an algebraic coordinate, and its count of
  13 DOFs lists theta_1 and theta_2 separately although a rigid gearbox
  ties them; here 1 mode per field gives 11 DOFs with "elastodyn" and 12
  with "two_spring": TFA1 TSS1 TTor1 B{1,2,3}F1 B{1,2,3}E1 GeAz DrTr [HSSTw]).

Blade flap/edge shapes are curvatures about the blade's local principal
axes, which turn with the structural twist along the span (ElastoDyn's
TwistedSF, `flexible_beam.twist_correction`): a flap mode also displaces
edgewise and vice versa (mass, gravity and centrifugal coupling; no
stiffness coupling), in the *pitched* blade frame. `structural_twist=False`
(scene flag `[effects] structural_twist = false`) drops the coupling: the
shapes then displace along the x/y axes of the pitched frame only.

Gyroscopic and Coriolis couplings (rotor speed with tower-top rotation,
blade vibration in the rotating frame) are part of the engine's inertial
terms and always present.

Coordinate names (modesel/vocabulary.py): tower TFA1.., TSS1.., TTor1..;
blades B{b}F1.., B{b}E1..; rigid: GeAz (generator azimuth, LSS side), DrTr
(drivetrain twist), HSSTw (HSS twist referred to the LSS), Yaw, PtfmSurge,
PtfmPitch. Output channels are Q_<name> like OpenFAST. A field absent from
the ModeSet has no DOF (rigid in that direction), so a scene without blade
DOFs allocates no blade states.

Damping ratios: the deck's; tower torsion (no ElastoDyn input) takes the
first fore-aft ratio.

Reaction coordinates (`reactions=True`): the tower base and each blade root
get rotation coordinates that are always fixed at 0 (TwrBsRxt, TwrBsRyt
about the ground x and y axes at the tower base; RootRxc<b>, RootRyc<b>
about the coned-blade x_c, y_c axes at blade b's root), and the hub a
translation along the shaft (LSShftTxa). Fixed, they change nothing in the
motion and cost nothing in the free equations; their rows of the full
equations give the reaction loads (TwrBsMxt, TwrBsMyt, RootMxc<b>,
RootMyc<b>, RotThrust; see outputs.py). With `reaction_forces=True` also the
rest of ElastoDyn's six load components at three places (vocabulary
TOWER_LOAD_REACTIONS, `root_reaction`): translations along and a rotation
about z at the tower base (TwrBsFxt, TwrBsFyt, TwrBsFzt, TwrBsMzt) and at each
blade root in the coned frame (RootFxc<b>, RootFyc<b>, RootFzc<b>, RootMzc<b>,
the last about the pitch axis), and all six at the yaw bearing in the
tower-top frame p, which the tower's deflection turns but the yaw does not
(YawBrFxp ... YawBrMzp); and at the shaft tip (the rotor apex) translations
along and rotations about the nonrotating shaft frame's y_s and z_s
(LSShftFys, LSShftFzs, LSSTipMys, LSSTipMzs, vocabulary SHAFT_LOAD_REACTIONS;
the rotating and strain-gauge components follow in outputs.py). The yaw bearing is then a body of its own,
carrying the yaw-bearing mass (YawBrMass, at the tower top) that ElastoDyn
counts below the bearing's loads, and the nacelle joins it.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from modesel.candidates.base import mode_shapes, shape_breakpoints
from modesel.modeset import ModeSet
from modesel.multibody.bodies import Joint, RigidBody, Rotation
from modesel.multibody.rotations import elementary_rotation
from modesel.model.flexible_beam import (FieldShapes, beam_quadrature, build_flexible_body,
                                         elastodyn_twisted, evaluate_field, interpolate_fine, tip_joint,
                                         twist_correction)
from modesel.model.flexible_beam import elastodyn_nodes as elastodyn_midpoint_nodes
from modesel.multibody.system import GearboxLoss, System
from modesel.vocabulary import (BLADE_FIELDS, FIELD_DIRECTION, RIGID_DOFS, SHAFT_THRUST_REACTION, TOWER_BASE_REACTION,
                                TOWER_BASE_REACTION_X, TOWER_FIELDS, TOWER_LOAD_REACTIONS, SHAFT_LOAD_REACTIONS, field_dofs, is_blade_body, is_blade_field,
                                root_reaction)

DRIVETRAINS = ("elastodyn", "two_spring")
FINE_POINTS = 801            # grid for the axial-shortening integrals
#: quadrature nodes per mode of the richest field on a beam (at least `min_nodes`):
#: mode k has about k half-waves, and Gauss quadrature of its curvature (or
#: torsion-rate) squared needs several points per half-wave, piecewise shapes
#: (`fem` elements) more. 40 nodes with 20 torsion modes put the 2nd-4th engine
#: frequencies 3.7 % below the converged ones; 12 per mode: < 0.1 %.
NODES_PER_MODE = 12
#: the engine works in a mass-orthogonal basis above this raw condition number
#: (beam mass only; the tower-top inertia raises it further): `linear` torsion
#: with 6 modes (8.8e7 raw, 1e10 with the RNA) put the 2nd frequency 1.2e-5 below
#: the 9-mode one, a Ritz-bound violation; 1e4 keeps round-off below ~1e-11
ENGINE_ILL_CONDITIONED = 1e4


@dataclass(frozen=True, eq=False)
class TurbineModel:
    """The System plus what effects and outputs need to know.

    field_dofs: field -> DOFs (blades: one tuple per blade). tips: body
    name -> tip dict of `build_flexible_body`. shapes: field -> callable
    x -> ShapeSet (x = s / L). weights: flexible body name -> (N,)
    quadrature weight of each node [m] (0 for a lumped tip mass), so that a
    load per unit length f(s) becomes the node force f(s_k) w_k. span:
    flexible body name -> (N,) node distance from the beam root [m].
    reactions: {output name: reaction coordinate}.
    """

    system: System
    turbine: object
    modeset: ModeSet
    field_dofs: dict = field(default_factory=dict)
    tips: dict = field(default_factory=dict)
    shapes: dict = field(default_factory=dict)
    weights: dict = field(default_factory=dict)
    span: dict = field(default_factory=dict)
    pitch: float = 0.0
    drivetrain: str = "elastodyn"
    reactions: dict = field(default_factory=dict)
    blade_fields: tuple = ()
    #: field -> (fine span [m], (count, 3, M) twist displacement correction)
    #: of the blade fields (`flexible_beam.twist_correction`); empty without twist
    blade_twist: dict = field(default_factory=dict)
    #: the blades use ElastoDyn's discrete nodes (`elastodyn_nodes`)
    blade_elastodyn_nodes: bool = False
    #: field -> (span grid [m], (count, 3, G) slope of each mode [1/m], pitched
    #: blade frame) on which `station_slopes` interpolates
    blade_slope: dict = field(default_factory=dict)
    #: the tower uses ElastoDyn's discrete nodes (`elastodyn_nodes`)
    tower_elastodyn_nodes: bool = False

    def blade_tip_displacement(self, dof: str) -> np.ndarray:
        """Tip displacement [m per unit coordinate] of blade DOF `dof` in its
        pitched blade frame (ElastoDyn's TwistedSF at the tip)."""
        body = f"blade{dof[1]}"
        return np.asarray(self.tips[body]["displacement"].get(dof, np.zeros(3)), float)
    def station_slopes(self, body: str, span: np.ndarray) -> np.ndarray:
        """(M, 3, ne) slope d(displacement)/ds of each elastic coordinate of a
        blade at `span` [m from the root] in its pitched frame [1/m]: the
        rotation of the blade section that ElastoDyn hands AeroDyn. On
        ElastoDyn's discrete nodes it is interpolated linearly between the
        root (0), the node slopes and the tip slope, as OpenFAST's line2
        mesh mapping carries ElastoDyn's node orientations to AeroDyn's nodes;
        else the analytic slope (with the structural-twist correction)."""
        b = self.system.body(body)
        span = np.clip(np.asarray(span, float), 0.0, self.turbine.blade.length)
        out = np.zeros((len(span), 3, b.n_elastic))
        col = 0
        for fld in self.blade_fields:
            grid, slope = self.blade_slope[fld]
            k = slope.shape[0]
            out[:, :, col:col + k] = np.transpose(interpolate_fine(grid, slope, span), (2, 1, 0))
            col += k
        return out

    def station_shapes(self, body: str, span: np.ndarray):
        """Undeformed positions s0 (M,3), shapes Phi (M,3,ne) and axial
        shortening matrices S (M,ne,ne) of extra points at `span` [m from the
        beam root] of a flexible body, in its body frame: the same fields
        as its nodes, evaluated at other stations (e.g. the AeroDyn nodes).
        S is interpolated linearly between the body's nodes, the root (0)
        and the tip (the tip shortening matrix)."""
        b = self.system.body(body)
        t = self.turbine
        beam = t.blade if is_blade_body(body) else t.tower
        L = beam.length
        span = np.clip(np.asarray(span, float), 0.0, L)
        s0 = np.zeros((len(span), 3))
        s0[:, 2] = span + (0.0 if is_blade_body(body) else beam.root_offset)
        ne = b.n_elastic
        Phi = np.zeros((len(span), 3, ne))
        col = 0
        for fld in (self.blade_fields if is_blade_body(body) else
                    [f for f in TOWER_FIELDS if f in self.field_dofs]):
            k = self.modeset[fld].count
            if fld != "tower_torsion":
                phi = self.shapes[fld](span / L).phi                 # (k, M)
                Phi[:, :, col:col + k] = FIELD_DIRECTION[fld][None, :, None] * phi.T[:, None, :]
                if fld in self.blade_twist:
                    fine_s, disp = self.blade_twist[fld]
                    Phi[:, :, col:col + k] += np.transpose(interpolate_fine(fine_s, disp, span), (2, 1, 0))
            col += k
        S = None
        if b.shortening is not None and ne:
            tip = self.tips[body]["shortening"][1]
            n_struct = len(self.span[body])
            grid = np.concatenate([[0.0], self.span[body][:n_struct], [L]])
            order = np.argsort(grid, kind="stable")
            vals = np.concatenate([np.zeros((1, ne, ne)), b.shortening[:n_struct], tip[None]])[order]
            grid = grid[order]
            S = np.empty((len(span), ne, ne))
            for i in range(ne):
                for j in range(ne):
                    S[:, i, j] = np.interp(span, grid, vals[:, i, j])
        return s0, Phi, S


def _shapes_for(turbine, fld, modes, rotor_speed):
    """Callable x -> ShapeSet of `fld`'s modes. A family whose raw mass
    matrix is ill-conditioned (condition number > ENGINE_ILL_CONDITIONED,
    e.g. 10 `polynomial` modes: 6e14) is used in its mass-orthogonal basis
    with unit tip values (`shape_integrals.conditioned_shapes`): same space of
    shapes, so the same physics, without the round-off that would otherwise
    swamp the equations (first shape unchanged; coordinates still read as tip
    deflections)."""
    from modesel.candidates.context import field_context
    from modesel.multibody.shape_integrals import conditioned_shapes
    ctx = field_context(turbine, fld, rotor_speed=rotor_speed)

    def raw(x):
        return mode_shapes(fld, modes.family, modes.count, ctx, x=x, **modes.params)

    beam = turbine.blade if is_blade_field(fld) else turbine.tower
    return conditioned_shapes(beam, raw, fld, threshold=ENGINE_ILL_CONDITIONED)[0]


def _quadrature_beam(turbine, beam, modeset: ModeSet, fields, rotor_speed: float):
    """`beam` with extra stations at the breakpoints of its fields' shapes
    (`Family.breakpoints`: element boundaries of `fem` shapes), properties
    interpolated linearly there (the same piecewise-linear functions, so the
    same beam): every quadrature interval then lies inside one element, where
    the shapes are polynomials that Gauss points integrate (almost) exactly."""
    from modesel.candidates.context import field_context
    extra = []
    for fld in fields:
        if fld in modeset:
            fm = modeset[fld]
            x = shape_breakpoints(fld, fm.family, fm.count,
                                  field_context(turbine, fld, rotor_speed=rotor_speed), **fm.params)
            if x is not None:
                extra.append(beam.span[0] + np.asarray(x, float) * beam.length)
    if not extra:
        return beam
    span = np.asarray(beam.span, float)
    new = np.union1d(span, np.concatenate(extra))
    new = new[np.concatenate([[True], np.diff(new) > 1e-9 * beam.length])]
    props = {k: np.interp(new, span, np.asarray(getattr(beam, k), float))
             for k in ("mass", "ei_1", "ei_2", "gj", "polar_inertia", "twist")}
    return replace(beam, span=new, **props)


def _elastodyn_discrete(turbine, beam: str, modeset: ModeSet, fields) -> bool:
    """Whether `beam` ("tower"/"blade") can use ElastoDyn's discrete model:
    the deck gave its node count. A rigid beam (no field) too: ElastoDyn
    integrates its mass on those nodes all the same (with the blade DOFs off,
    the converged quadrature's rotor differed from OpenFAST's by 0.18 kN of
    weight along the tilted shaft, YawBrMyp by 1.3 %). Any family:
    the deck's node count is part of the case, and ElastoDyn integrates
    whatever shapes it is given (the deck's polynomials, or the fits that
    `modesel export` writes) on those nodes; the converged quadrature of the
    same shapes gives other frequencies (NREL 5-MW, 17 blade nodes: flap 1
    +1.4 %, edge 1 +0.9 %), a difference the export cannot remove. A field
    with more modes than the beam has nodes (its node sums would be
    singular) takes the converged quadrature."""
    count = getattr(turbine, f"{beam}_nodes", None)
    used = [modeset[f].count for f in fields if f in modeset]
    return bool(count) and max(used, default=0) <= int(count)


def _nodes_for(modeset: ModeSet, fields, min_nodes: int) -> int:
    """Quadrature nodes of a beam carrying `fields` (NODES_PER_MODE)."""
    counts = [modeset[f].count for f in fields if f in modeset]
    return max(int(min_nodes), NODES_PER_MODE * max(counts, default=0))


def _blade_from_root(body, tip: dict, root: float, tip_mass: float):
    """`body` (built with node z = root offset + s) with its origin at the
    blade root, and the tip brake `tip_mass` [kg] as a last node at the tip
    (zero quadrature weight; it moves with the tip shapes and shortening)."""
    nodes = body.nodes - np.array([0.0, 0.0, root])
    if tip_mass <= 0:
        return replace(body, nodes=nodes)
    tip_phi = np.zeros((1, 3, body.n_elastic))
    for i, d in enumerate(body.dofs):
        tip_phi[0, :, i] = tip["displacement"].get(d, np.zeros(3))
    shortening = None if body.shortening is None else \
        np.concatenate([body.shortening, tip["shortening"][1][None]], axis=0)
    return replace(body, nodes=np.vstack([nodes, [0.0, 0.0, tip["length"]]]),
                   node_mass=np.append(body.node_mass, tip_mass),
                   shapes=np.concatenate([body.shapes, tip_phi], axis=0), shortening=shortening)


def _undamped(body):
    """`body` without structural damping."""
    return body if body.damping is None else replace(body, damping=np.zeros_like(body.damping))


def build_turbine(turbine, modeset: ModeSet, *, free=(), fixed=None, prescribed=None,
                  gravity: bool = True, geometric_stiffening: bool = True,
                  rotor_speed_for_shapes: float = 0.0, pitch: float = 0.0,
                  include_blades: bool = True, min_nodes: int = 40, drivetrain: str = "elastodyn",
                  gearbox_inertia: float = 0.0, reactions: bool = False, damping: bool = True,
                  structural_twist: bool = True, elastodyn_nodes: bool = False,
                  reaction_forces: bool = False) -> TurbineModel:
    """Body tree of `turbine` with the elastic fields of `modeset`.

    free: rigid DOFs integrated in time (subset of RIGID_DOFS); elastic DOFs
    of every field in `modeset` are free. fixed: {name: value}; prescribed:
    {name: Prescribed}. pitch [rad] collective (fixed). drivetrain:
    "elastodyn" or "two_spring" (then HSSTw is a DOF and the gearbox has
    `gearbox_inertia` [kg m^2, LSS side] about the shaft). reactions: add
    the fixed reaction coordinates (module doc); reaction_forces: with
    them, those of the forces and remaining moments too. damping: False builds the
    beams without structural damping (D_e = 0). min_nodes: quadrature nodes
    per beam, raised to NODES_PER_MODE per mode for many modes.
    structural_twist: blade shapes turn with the structural twist (module
    doc). elastodyn_nodes: a beam with a field (any family) is integrated on
    the deck's analysis nodes (TwrNodes, BldNodes) with ElastoDyn's midpoint
    rule, discrete twisted shapes and axial-shortening sums
    (`_elastodyn_discrete`), i.e. the discrete model OpenFAST solves for
    those shapes, instead of the converged quadrature.
    Units SI.
    """
    fixed = dict(fixed or {})
    prescribed = dict(prescribed or {})
    t = turbine
    bodies = []
    fdofs = {}
    tips = {}
    shapes = {}
    weights = {}
    spans = {}
    blade_twist = {}
    blade_slope = {}

    # ---- platform (only when a platform DOF is used)
    uses_platform = any(d in ("PtfmSurge", "PtfmPitch") for d in list(free) + list(fixed) + list(prescribed))
    tower_parent = None
    tower_offset = np.array([0.0, 0.0, t.tower_base_height])
    if uses_platform:
        pj = Joint(None, np.array([0.0, 0.0, t.platform_ref_z]), translation={"PtfmSurge": np.array([1.0, 0, 0])},
                   rotations=[Rotation(1, {"PtfmPitch": 1.0})])
        cm = np.array(t.platform_cm, float) - np.array([0.0, 0.0, t.platform_ref_z])
        bodies.append(RigidBody("platform", pj, t.platform_mass, cm, np.diag(t.platform_inertia)))
        tower_parent = "platform"
        tower_offset = np.array([0.0, 0.0, t.tower_base_height - t.platform_ref_z])

    # ---- tower
    reaction_names = {}
    tower_rot = []
    tower_moves = {}
    reaction_forces = reactions and reaction_forces
    if reactions:
        tower_rot = [Rotation(0, {TOWER_BASE_REACTION_X: 1.0}), Rotation(1, {TOWER_BASE_REACTION: 1.0})]
        reaction_names["TwrBsMxt"] = TOWER_BASE_REACTION_X
        reaction_names["TwrBsMyt"] = TOWER_BASE_REACTION
    if reaction_forces:
        names = TOWER_LOAD_REACTIONS
        tower_rot.append(Rotation(2, {names["TwrBsMzt"]: 1.0}))
        tower_moves = {names[f"TwrBsF{a}t"]: e for a, e in zip("xyz", np.eye(3))}
        reaction_names.update({c: names[c] for c in ("TwrBsFxt", "TwrBsFyt", "TwrBsFzt", "TwrBsMzt")})
    tower_nodes = _nodes_for(modeset, TOWER_FIELDS, min_nodes)
    tower_beam = _quadrature_beam(t, t.tower, modeset, TOWER_FIELDS, 0.0)
    tower_ed = elastodyn_nodes and _elastodyn_discrete(t, "tower", modeset, TOWER_FIELDS)
    if tower_ed:
        s_nodes, w_nodes = elastodyn_midpoint_nodes(t.tower.length, t.tower_nodes)
    else:
        s_nodes, w_nodes = beam_quadrature(tower_beam.span, tower_nodes)
    fine_s = np.linspace(0, t.tower.length, FINE_POINTS)
    tower_fields = []
    for fld in TOWER_FIELDS:
        if fld in modeset:
            modes = modeset[fld]
            dofs = field_dofs(fld, modes.count)
            fdofs[fld] = dofs
            fn = _shapes_for(t, fld, modes, 0.0)
            ratios = t.tower.damping_ratio.get(fld) or (
                tuple(t.tower.damping_ratio.get("tower_fa", ()))[:1] if fld == "tower_torsion" else ())
            tower_fields.append(evaluate_field(fld, dofs, fn, s_nodes, t.tower.length, fine_s, ratios,
                                               getattr(t.tower, "stiffness_tuners", {}).get(fld, ())))
            shapes[fld] = fn
    tower, ttip = build_flexible_body("tower", Joint(tower_parent, tower_offset, translation=tower_moves, rotations=tower_rot), tower_beam,
                                      tower_fields, shortening=geometric_stiffening, min_nodes=tower_nodes,
                                      ed_nodes=(s_nodes, w_nodes) if tower_ed else None)
    bodies.append(tower if damping else _undamped(tower))
    tips["tower"] = ttip
    weights["tower"] = w_nodes
    spans["tower"] = s_nodes

    # ---- nacelle (yaw bearing + nacelle), ElastoDyn: only the yaw inertia
    ncm = np.array(t.nacelle_cm, float)
    if reaction_forces:
        # the yaw bearing (its mass at the tower top) and the nacelle on it, joined by
        # the yaw and the six reaction coordinates of the bearing's loads (frame p)
        names = TOWER_LOAD_REACTIONS
        bodies.append(RigidBody("yaw_bearing", tip_joint("tower", ttip), t.yaw_bearing_mass))
        nj = Joint("yaw_bearing", translation={names[f"YawBrF{a}p"]: e for a, e in zip("xyz", np.eye(3))},
                   rotations=[Rotation(0, {names["YawBrMxp"]: 1.0}), Rotation(1, {names["YawBrMyp"]: 1.0}),
                              Rotation(2, {"Yaw": 1.0, names["YawBrMzp"]: 1.0})])
        reaction_names.update({c: names[c] for c in names if c.startswith("YawBr")})
        mn, cm = t.nacelle_mass, ncm
    else:
        nj = tip_joint("tower", ttip, extra_rotations=[Rotation(2, {"Yaw": 1.0})])
        mn = t.nacelle_mass + t.yaw_bearing_mass
        cm = ncm * t.nacelle_mass / mn if mn > 0 else np.zeros(3)
    Izz = max(t.nacelle_yaw_inertia - t.nacelle_mass * (ncm[0] ** 2 + ncm[1] ** 2), 0.0)
    bodies.append(RigidBody("nacelle", nj, mn, cm, np.diag([0.0, 0.0, Izz])))

    # ---- shaft geometry: x_s along the (tilted) shaft, downwind (eq. 17)
    tilt = elementary_rotation(1, -t.shaft_tilt)
    apex = np.array([0.0, 0.0, t.twr2shft]) + t.apex_overhang * tilt[:, 0]
    rotor_angle = {"GeAz": 1.0, "DrTr": 1.0}
    shaft_moves = {SHAFT_THRUST_REACTION: tilt[:, 0].copy()} if reactions else {}
    shaft_turns = []
    if reaction_forces:
        # the shaft tip's remaining loads in the nonrotating frame s: translations along
        # and rotations about y_s and z_s, ahead of the rotor's spin about x_s
        names = SHAFT_LOAD_REACTIONS
        shaft_moves.update({names["LSShftFys"]: tilt[:, 1].copy(), names["LSShftFzs"]: tilt[:, 2].copy()})
        shaft_turns = [Rotation(1, {names["LSSTipMys"]: 1.0}), Rotation(2, {names["LSSTipMzs"]: 1.0})]
        reaction_names.update(names)
    hj = Joint("nacelle", apex, tilt, rotations=shaft_turns + [Rotation(0, rotor_angle)], translation=shaft_moves)
    if reactions:
        reaction_names["RotThrust"] = SHAFT_THRUST_REACTION
        if "DrTr" not in free and "DrTr" not in prescribed and drivetrain == "elastodyn":
            # a rigid drivetrain (ElastoDyn's DrTrDOF off): DrTr held at 0 turns the rotor
            # alone, so its row is the torque the rotor exerts on the shaft (LSShftMxa)
            reaction_names["RotTorq"] = "DrTr"
    # hub inertia about its CM: HubIner about the shaft; a two-blader's also about
    # the teeter axis, y here (perpendicular to blade 1 along z), ElastoDyn's Hubf2Iner f2
    bodies.append(RigidBody("hub", hj, t.hub_mass, np.array([t.hub_cm, 0.0, 0.0]),
                            np.diag([t.hub_inertia, t.hub_teeter_inertia, 0.0])))
    gj = Joint("nacelle", apex, tilt, rotations=[Rotation(0, {"GeAz": t.gearbox_ratio})])
    bodies.append(RigidBody("generator", gj, 0.0, np.zeros(3), np.diag([t.generator_inertia, 0.0, 0.0])))
    if drivetrain == "two_spring":
        # rigid gearbox, LSS-side angle theta_1 = GeAz + HSSTw (eq. 19-20)
        gbj = Joint("nacelle", apex, tilt, rotations=[Rotation(0, {"GeAz": 1.0, "HSSTw": 1.0})])
        bodies.append(RigidBody("gearbox", gbj, 0.0, np.zeros(3), np.diag([gearbox_inertia, 0.0, 0.0])))
    elif drivetrain != "elastodyn":
        raise ValueError(drivetrain)

    # ---- blades (eq. 26-29: azimuth, precone, pitch; body origin at the root)
    blade_fields = ()
    blade_ed = False
    if include_blades:
        blade_fields_spec = [(f, modeset[f]) for f in BLADE_FIELDS if f in modeset]
        blade_fields = tuple(f for f, _ in blade_fields_spec)
        L = t.blade.length
        blade_nodes = _nodes_for(modeset, BLADE_FIELDS, min_nodes)
        blade_beam = _quadrature_beam(t, t.blade, modeset, BLADE_FIELDS, rotor_speed_for_shapes)
        blade_ed = elastodyn_nodes and _elastodyn_discrete(t, "blade", modeset, BLADE_FIELDS)
        if blade_ed:
            sb_nodes, wb_nodes = elastodyn_midpoint_nodes(L, t.blade_nodes)
        else:
            sb_nodes, wb_nodes = beam_quadrature(blade_beam.span, blade_nodes)
        fine_b = np.linspace(0, L, FINE_POINTS)
        evaluated = {}
        twisted = {}
        theta_fine = np.interp(fine_b, t.blade.span - t.blade.span[0], t.blade.twist)
        for fld, modes in blade_fields_spec:
            fn = _shapes_for(t, fld, modes, rotor_speed_for_shapes)
            evaluated[fld] = (fn(sb_nodes / L), fn(np.array([1.0])), fn(fine_b / L))
            shapes[fld] = fn
            if blade_ed:
                # ElastoDyn's discrete twisted shapes replace the analytic ones at
                # the nodes and tip (as differences to e phi, see FieldShapes)
                at_nodes, at_tip = evaluated[fld][:2]
                theta = np.interp(sb_nodes, t.blade.span - t.blade.span[0], t.blade.twist)
                disp, slope, dtip, slope_tip = elastodyn_twisted(fld, float(wb_nodes[0]), at_nodes.ddphi / L**2,
                                                                 theta if structural_twist else 0.0 * theta)
                e = FIELD_DIRECTION[fld][None, :, None]
                dn = disp - e * at_nodes.phi[:, None, :]
                dt_ = dtip - e[:, :, 0] * at_tip.phi[:, :1]
                twisted[fld] = (None, slope - e * (at_nodes.dphi / L)[:, None, :], dn, dt_)
                grid = np.concatenate([[0.0], sb_nodes, [L]])
                blade_twist[fld] = (grid, np.concatenate([np.zeros(dn.shape[:2] + (1,)), dn, dt_[:, :, None]],
                                                         axis=-1))
                blade_slope[fld] = (grid, np.concatenate([np.zeros(dn.shape[:2] + (1,)), slope,
                                                          slope_tip[:, :, None]], axis=-1))
            elif structural_twist and np.any(t.blade.twist != 0.0):
                disp, slope = twist_correction(fld, fine_b, evaluated[fld][2].ddphi / L**2, theta_fine)
                twisted[fld] = (disp, slope, interpolate_fine(fine_b, disp, sb_nodes), disp[:, :, -1])
                blade_twist[fld] = (fine_b, disp)
            if fld not in blade_slope:
                analytic = FIELD_DIRECTION[fld][None, :, None] * (evaluated[fld][2].dphi / L)[:, None, :]
                blade_slope[fld] = (fine_b, analytic + (twisted[fld][1] if fld in twisted else 0.0))
        root = t.blade.root_offset
        for b in range(1, t.num_blades + 1):
            # ElastoDyn's blade frame g: turned by a two-blader's Delta3 about the shaft (SetCoordSy)
            psi = 2 * np.pi * (b - 1) / t.num_blades + t.delta3
            coned = elementary_rotation(0, psi) @ elementary_rotation(1, t.precone[b - 1])
            offset = coned @ np.array([0.0, 0.0, root])
            if reactions:
                about_z = {root_reaction(b, "z"): 1.0} if reaction_forces else {}
                moves = {root_reaction(b, a, "T"): coned[:, k].copy() for k, a in enumerate("xyz")} \
                    if reaction_forces else {}
                bj = Joint("hub", offset, coned, translation=moves,
                           rotations=[Rotation(0, {root_reaction(b, "x"): 1.0}),
                                      Rotation(1, {root_reaction(b): 1.0}), Rotation(2, about_z, -pitch)])
                reaction_names[f"RootMxc{b}"] = root_reaction(b, "x")
                reaction_names[f"RootMyc{b}"] = root_reaction(b)
                if reaction_forces:
                    reaction_names[f"RootMzc{b}"] = root_reaction(b, "z")
                    reaction_names.update({f"RootF{a}c{b}": root_reaction(b, a, "T") for a in "xyz"})
            else:
                bj = Joint("hub", offset, coned @ elementary_rotation(2, -pitch))
            flds = []
            for fld, modes in blade_fields_spec:
                dofs = field_dofs(fld, modes.count, blade=b)
                fdofs.setdefault(fld, []).append(dofs)
                at_nodes, at_tip, fine = evaluated[fld]
                tw = twisted.get(fld)
                flds.append(FieldShapes(fld, dofs, at_nodes.phi, at_nodes.dphi / L, at_nodes.ddphi / L**2,
                                        at_tip.phi[:, 0], at_tip.dphi[:, 0] / L, fine.dphi / L,
                                        tuple(t.blade.damping_ratio.get(fld, ())),
                                        tuple(getattr(t.blade, "stiffness_tuners", {}).get(fld, ())),
                                        twist_nodes=None if tw is None else tw[2],
                                        twist_tip=None if tw is None else tw[3],
                                        twist_slope_fine=None if tw is None or blade_ed else tw[1],
                                        twist_slope_nodes=tw[1] if tw is not None and blade_ed else None))
            body, btip = build_flexible_body(f"blade{b}", bj, blade_beam, flds,
                                             shortening=geometric_stiffening, min_nodes=blade_nodes,
                                             ed_nodes=(sb_nodes, wb_nodes) if blade_ed else None)
            btip = {**btip, "length": btip["length"] - root}
            body = _blade_from_root(body, btip, root, t.tip_mass[b - 1])
            w_body = np.append(wb_nodes, 0.0) if t.tip_mass[b - 1] > 0 else wb_nodes
            bodies.append(body if damping else _undamped(body))
            tips[f"blade{b}"] = btip
            weights[f"blade{b}"] = w_body
            spans[f"blade{b}"] = sb_nodes

    elastic = [d for f in TOWER_FIELDS for d in fdofs.get(f, ())]
    for f in BLADE_FIELDS:
        for dofs in fdofs.get(f, []):
            elastic += list(dofs)
    free_all = elastic + [d for d in RIGID_DOFS if d in free]
    # ElastoDyn's gearbox friction on the generator azimuth's equation (GBoxEff < 100 %, multibody/gearbox.py)
    loss = GearboxLoss("generator", "GeAz", t.gearbox_efficiency) if t.gearbox_efficiency < 1.0 else None
    if loss is not None and drivetrain != "elastodyn":
        raise ValueError("gearbox losses are modelled with the elastodyn drivetrain only")
    system = System(bodies, free_all, fixed, prescribed, t.gravity if gravity else 0.0, gearbox_loss=loss)
    return TurbineModel(system, t, modeset, fdofs, tips, shapes, weights, spans, float(pitch), drivetrain,
                        reaction_names, blade_fields, blade_twist, bool(include_blades and blade_ed),
                        blade_slope, tower_elastodyn_nodes=bool(tower_ed))
