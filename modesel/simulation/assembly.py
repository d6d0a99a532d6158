"""A scene turned into equations and effects: `Built`, made by `build`.

A scene switches on only the DOFs and effects it calls for: fields without
modes have no states, and an effect that is off is not imported, not
constructed and never evaluated (`effects.select`).

Right-hand side: M(q) qdd = F(q, qd, t) + loads, where the loads are the
switched-on effects' generalised forces and node forces (effects/base.py).
Every bundled effect runs inside the engine's compiled loop: linear
spring-dampers (drivetrain) and model options (damping, pitch) through the
kernel's own arrays, effects with loads at every step (wind, aero, tower
drag, generator torque) packed by `effects.compiled` (`Built.rhs`).
`Built.M_F` (Python, per right-hand side) is the reference path.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from modesel.modeset import ModeSet
from modesel.model.effects import select as select_effects
from modesel.model.effects.base import BuildSpec
from modesel.model.template import build_turbine
from modesel.multibody.compiled import CompiledRHS, spring_dampers
from modesel.multibody.kane import KaneEquations
from modesel.multibody.packing import with_load_points
from modesel.multibody.system import Prescribed
from modesel.simulation.equilibrium import static_equilibrium
from modesel.simulation.scene import Scene
from modesel.vocabulary import ROTOR_AZIMUTH, is_blade_field

#: ElastoDyn initial condition of the first mode of each field, and its sign
#: (ElastoDyn: Q_TSS along -y, TTDspSS along +y); blade fields: every blade
FIELD_INITIAL = {"tower_fa": ("TTDspFA", 1.0), "tower_ss": ("TTDspSS", -1.0),
                 "tower_torsion": ("TTDspTwst", 1.0), "blade_flap": ("OoPDefl", 1.0),
                 "blade_edge": ("IPDefl", 1.0)}
#: ElastoDyn initial condition of each rigid-body coordinate
RIGID_INITIAL = {ROTOR_AZIMUTH: "Azimuth", "Yaw": "NacYaw", "PtfmSurge": "PtfmSurge", "PtfmPitch": "PtfmPitch"}


class FrameCache:
    """Body frames (R, vec) at (q_all, qd_all) (`multibody.kinematics.FrameKinematics`),
    computed once per pair of state arrays: every effect of one right-hand
    side shares them. The arrays are identified by identity (and held, so
    the identity cannot be reused); do not modify them in place."""

    def __init__(self, eq: KaneEquations):
        self.eq = eq
        self.kinematics = None
        self.state = (None, None)
        self.result = None

    def __call__(self, q_all, qd_all):
        held_q, held_qd = self.state
        if q_all is not held_q or qd_all is not held_qd:
            self.result = self._kinematics()(q_all, qd_all)
            self.state = (q_all, qd_all)
        return self.result

    def along(self, Q, QD):
        """The frames at many states (rows of Q, QD) in one compiled call
        (`FrameKinematics.along`); the cache is left as it is."""
        return self._kinematics().along(Q, QD)

    def hold(self, q_all, qd_all, frames):
        """Take `frames` (R, vec) as the frames at (q_all, qd_all), computed
        beforehand (`along`): the effects evaluated next at that state share
        them."""
        self.state, self.result = (q_all, qd_all), frames

    def _kinematics(self):
        if self.kinematics is None:
            from modesel.multibody.kinematics import FrameKinematics
            self.kinematics = FrameKinematics(self.eq)
        return self.kinematics


@dataclass(frozen=True, eq=False)
class Built:
    """A scene turned into equations and effects, ready to integrate or
    linearise. q0 [m, rad], qd0 [m/s, rad/s]: initial free coordinates;
    linear: the effects' spring-dampers [(row, column, k, c[, neutral])]."""

    scene: Scene
    model: object
    eq: KaneEquations
    q0: np.ndarray
    qd0: np.ndarray
    effects: list
    linear: list = field(default_factory=list)
    frame_cache: FrameCache | None = field(default=None, repr=False)

    def __post_init__(self):
        idx = self.eq.index
        lin = spring_dampers(self.linear)
        derived = {"frame_cache": self.frame_cache or FrameCache(self.eq),
                   "_lin_rows": np.array([idx[r] for r, _, _, _, _ in lin], dtype=int),
                   "_lin_cols": np.array([idx[c] for _, c, _, _, _ in lin], dtype=int),
                   "_lin_k": np.array([k for _, _, k, _, _ in lin], float),
                   "_lin_c": np.array([c for _, _, _, c, _ in lin], float),
                   "_lin_q0": np.array([q0 for _, _, _, _, q0 in lin], float)}
        for name, value in derived.items():      # set once, at construction
            object.__setattr__(self, name, value)

    # ------------------------------------------------------------- effects
    def effect(self, name: str):
        """The switched-on effect `name`, or None."""
        return next((e for e in self.effects if e.name == name), None)

    @property
    def acting(self) -> list:
        """Effects that add loads at every right-hand side."""
        return [e for e in self.effects if e.loads]

    @property
    def kinked(self) -> bool:
        """Whether an acting effect's loads have kinks in the state (`Effect.kinked`)."""
        return any(e.kinked for e in self.acting)

    def frames(self, q_all, qd_all):
        """Body frames at (q_all, qd_all), shared by the effects (`FrameCache`)."""
        return self.frame_cache(q_all, qd_all)

    def hub_height(self) -> float:
        """Height of the rotor apex above the ground at rest [m]."""
        q_all, qd_all, _ = self.eq.full_state(np.zeros_like(self.q0), np.zeros_like(self.qd0), 0.0)
        states = self.eq.kinematics(q_all, qd_all)
        return float(states[self.eq.body_index["hub"]].r[2])

    def loads(self, t, q_all, qd_all):
        """(generalised forces (n_all,) [N, N m], node forces {body: (N,3)} [N])
        of all switched-on effects at one state (all coordinates)."""
        gen = np.zeros(self.eq.n_all)
        if len(self._lin_rows):
            np.subtract.at(gen, self._lin_rows, self._lin_k * (q_all[self._lin_cols] - self._lin_q0)
                           + self._lin_c * qd_all[self._lin_cols])
        nodes = {}
        for e in self.acting:
            e(self, t, q_all, qd_all, gen, nodes)
        return gen, nodes

    def M_F(self, t, q, qd):
        """M and F of the free coordinates (M qdd = F) with all loads."""
        if not self.acting and not self.linear:
            return self.eq.evaluate(q, qd, t)
        q_all, qd_all, _ = self.eq.full_state(q, qd, t)
        gen, nodes = self.loads(t, q_all, qd_all)
        return self.eq.evaluate(q, qd, t, node_forces=nodes or None, generalized=gen)

    def rhs(self, *, all_rows=False):
        """The right-hand side for `integrate`: a `CompiledRHS` with the
        effects' loads packed into the compiled loop (`effects.compiled`;
        each call packs a fresh state), else `M_F` (an effect without a
        compiled form)."""
        if not hasattr(self.eq, "compiled_rhs"):
            return self.M_F
        if not self.acting:
            return self.eq.compiled_rhs(self.linear, all_rows=all_rows)
        from modesel.model.effects.compiled import CHANNEL_FLAG, pack_loads
        packed = self.eq.packed_full if all_rows else self.eq.packed_free
        transfers, shared = {}, set()
        for e in self.acting:                   # a body loaded by two effects keeps its nodes
            for name, T in e.load_points(self).items():
                if name in transfers:
                    shared.add(name)
                transfers[name] = T
        packed = with_load_points(packed, self.eq, {k: T for k, T in transfers.items() if k not in shared})
        packing = pack_loads(self, packed)
        if packing is None:
            return self.M_F
        loads, channels = packing
        return CompiledRHS(self.eq, self.linear, all_rows=all_rows, loads=loads, channels=channels,
                           channel_flag=CHANNEL_FLAG, packed=packed)


def effective_modeset(scene: Scene, modeset: ModeSet | None) -> ModeSet:
    """The scene's active fields, with shapes from `modeset` where it has them."""
    if modeset is None:
        return scene.modes
    fields = {f: modeset[f] if f in modeset else scene.modes[f] for f in scene.fields}
    return ModeSet(fields)


def build(scene: Scene, modeset: ModeSet | None = None, *, reactions: bool = False,
          reaction_forces: bool = False) -> Built:
    """Equations and effects of `scene` (with `modeset` overriding its
    shapes). reactions: add the reaction coordinates of the load outputs
    (TwrBsMyt, RootMyc<b>; model/template.py); reaction_forces: and those of
    the forces and remaining moments (TwrBsFxt, YawBrMyp, RootFzc<b> ...). Effect life cycle: effects/base.py."""
    ms = effective_modeset(scene, modeset)
    init = scene.initial
    effects = list(select_effects(scene))
    spec = BuildSpec(free=list(scene.free), fixed=dict(scene.fixed), prescribed={},
                     pitch=collective(init.get("BlPitch", 0.0)), damping=False, reactions=reactions,
                     reaction_forces=reaction_forces)
    if ROTOR_AZIMUTH in scene.constant_speed:
        spec.prescribed[ROTOR_AZIMUTH] = Prescribed(init.get("Azimuth", 0.0), scene.constant_speed[ROTOR_AZIMUTH])
    for e in effects:
        e.configure(spec)
    if ROTOR_AZIMUTH not in spec.free and ROTOR_AZIMUTH not in spec.prescribed:
        spec.fixed.setdefault(ROTOR_AZIMUTH, init.get("Azimuth", 0.0))
    model = build_turbine(scene.turbine, ms, free=spec.free, fixed=spec.fixed, prescribed=spec.prescribed,
                          gravity=bool(scene.effect("gravity")),
                          geometric_stiffening=bool(scene.effect("geometric_stiffening")),
                          structural_twist=bool(scene.effect("structural_twist")),
                          elastodyn_nodes=bool(scene.effect("elastodyn_nodes", False)),
                          rotor_speed_for_shapes=scene.constant_speed.get(ROTOR_AZIMUTH, init.get("RotSpeed", 0.0)),
                          pitch=spec.pitch, drivetrain=spec.drivetrain, gearbox_inertia=spec.gearbox_inertia,
                          reactions=spec.reactions, damping=spec.damping,
                          reaction_forces=spec.reaction_forces)
    for e in effects:
        model = e.prepare(model)
    eq = KaneEquations(model.system)
    q0, qd0 = initial_state(model, init)
    bare = Built(scene, model, eq, q0, qd0, effects)
    for e in effects:
        e.setup(bare)
    built = replace(bare, linear=[term for e in effects for term in e.linear(bare)])
    if init.get("equilibrium"):
        built = replace(built, q0=static_equilibrium(built))
    return built


def initial_state(model, init: dict):
    """(q0, qd0) of the free coordinates from ElastoDyn-named initial
    conditions (SI: m, rad, rad/s; FIELD_INITIAL, RIGID_INITIAL)."""
    pos = {n: i for i, n in enumerate(model.system.free)}
    q0 = np.zeros(len(pos))
    qd0 = np.zeros(len(pos))
    for fld, dofs in model.field_dofs.items():
        if is_blade_field(fld):
            continue                                              # below, both fields at once
        key, sign = FIELD_INITIAL[fld]
        if dofs and dofs[0] in pos:
            q0[pos[dofs[0]]] = sign * init.get(key, 0.0)
    n_blades = max((len(model.field_dofs.get(f, [])) for f in ("blade_flap", "blade_edge")), default=0)
    for b in range(n_blades):
        for dof, value in initial_blade(model, b, init.get("OoPDefl", 0.0), init.get("IPDefl", 0.0)).items():
            if dof in pos:
                q0[pos[dof]] = value
    for dof, key in RIGID_INITIAL.items():
        if dof in pos:
            q0[pos[dof]] = init.get(key, 0.0)
    if ROTOR_AZIMUTH in pos:
        qd0[pos[ROTOR_AZIMUTH]] = init.get("RotSpeed", 0.0)
    return q0, qd0


def initial_blade(model, b: int, oop: float, ip: float) -> dict:
    """{DOF: value} of blade index `b` (0-based) whose tip is deflected by
    `oop` out of plane and `ip` in plane [m], along the x and y axes of the
    coned (unpitched) blade frame, as ElastoDyn's InitBlDefl: the whole
    deflection goes to the first flap mode and the first edge mode (the
    second flap mode starts at 0; without flap DOFs, the first edge mode
    alone), whose tip displacements (twisted shapes, pitched frame) are
    turned by the pitch into the coned frame; the 2x2 system is solved, or,
    with one mode, its least-squares solution (ElastoDyn's formula)."""
    cols = []
    for fld in ("blade_flap", "blade_edge"):
        groups = model.field_dofs.get(fld, [])
        if b < len(groups) and groups[b]:
            cols.append(groups[b][0])
    if not cols or (oop == 0.0 and ip == 0.0):
        return {}
    c, s = np.cos(model.pitch), np.sin(model.pitch)
    A = np.empty((2, len(cols)))
    for k, dof in enumerate(cols):
        u = model.blade_tip_displacement(dof)
        A[:, k] = (u[0] * c + u[1] * s, -u[0] * s + u[1] * c)        # pitched -> coned frame
    target = np.array([oop, ip])
    if len(cols) == 2 and abs(np.linalg.det(A)) > 1e-12:
        x = np.linalg.solve(A, target)
    else:
        x = np.linalg.lstsq(A, target, rcond=None)[0]
    return dict(zip(cols, x))


def collective(pitch) -> float:
    """Collective pitch [rad] from a scalar or per-blade values (their mean)."""
    return float(np.mean(np.atleast_1d(pitch)))
