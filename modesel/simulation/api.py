"""Front functions of the simulator: `load_scene`, `build`, `simulate`,
`linearize_scene`. A scene switches on only the DOFs and effects it calls
for: fields without modes have no states, and an effect that is off is
not imported, not constructed and never evaluated (`effects.select`).

Right-hand side: M(q) qdd = F(q, qd, t) + loads, where the loads are the
switched-on effects' generalised forces and node forces (effects/base.py).
A scene whose effects are only linear spring-dampers (drivetrain) or model
options (damping, pitch, locked generator) integrates in the engine's
compiled loop; effects with loads at every step (aero, tower drag,
generator torque) go through `Built.M_F`.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from modesel.errors import ModeselError, PhysicallyUnstable, SimulationDiverged
from modesel.modeset import ModeSet
from modesel.multibody import linearize as _lin
from modesel.model.effects import select as select_effects
from modesel.model.effects.base import BuildSpec
from modesel.multibody.kane import KaneEquations
from modesel.multibody.integrate import choose_method, integrate
from modesel.model.template import build_turbine
from modesel.model.outputs import channels
from modesel.simulation.scene import Scene, load_scene  # noqa: F401  (re-export)
from modesel.multibody.system import Prescribed

#: coordinates of the drivetrain springs, included in a static equilibrium
DRIVETRAIN_DOFS = ("DrTr", "HSSTw")
#: rotor azimuths over which the multi-blade linearisation is averaged
MBC_AZIMUTHS = 12
#: rigid-body coordinates: their zero-frequency (or drifting) modes are not elastic instabilities
RIGID_BODY_DOFS = ("GeAz", "Yaw", "PtfmSurge", "PtfmPitch")
#: a real eigenvalue below this fraction of the largest |eigenvalue| (plus an
#: absolute 1e-6 1/s) is round-off of the finite-difference linearisation
STABILITY_NOISE = 1e-7


@dataclass
class SimulationResult:
    """Outputs ('Time' + OpenFAST channels), DOF count and cost."""

    outputs: pd.DataFrame
    n_dofs: int
    wall_time_s: float
    simulated_time_s: float
    dof_names: list = field(default_factory=list)
    method: str = ""
    stiffness_ratio: float = float("nan")
    n_rhs: int = 0

    @property
    def speed(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.simulated_time_s / max(self.wall_time_s, 1e-12)


@dataclass
class Built:
    """A scene turned into equations and effects, ready to integrate or linearise."""

    scene: Scene
    model: object
    eq: KaneEquations
    q0: np.ndarray
    qd0: np.ndarray
    effects: list
    linear: list = field(default_factory=list)

    def __post_init__(self):
        self._frames = None
        self._frames_state = (None, None)
        self._set_linear(self.linear)

    def _set_linear(self, terms):
        self.linear = list(terms)
        idx = self.eq.index
        self._lin_rows = np.array([idx[r] for r, _, _, _ in self.linear], dtype=int)
        self._lin_cols = np.array([idx[c] for _, c, _, _ in self.linear], dtype=int)
        self._lin_k = np.array([k for _, _, k, _ in self.linear], float)
        self._lin_c = np.array([c for _, _, _, c in self.linear], float)

    # ------------------------------------------------------------- effects
    def effect(self, name: str):
        """The switched-on effect `name`, or None."""
        return next((e for e in self.effects if e.name == name), None)

    @property
    def acting(self) -> list:
        """Effects that add loads at every right-hand side."""
        return [e for e in self.effects if e.loads]

    def frames(self, q_all, qd_all):
        """Body frames (R, vec) at (q_all, qd_all) (`effects.kinematics.FrameKinematics`),
        computed once per pair of state arrays: every effect of one right-hand
        side shares them. The arrays are identified by identity (and held, so
        the identity cannot be reused); do not modify them in place."""
        if self._frames is None:
            from modesel.multibody.kinematics import FrameKinematics
            self._frames = FrameKinematics(self.eq)
        held_q, held_qd = self._frames_state
        if q_all is not held_q or qd_all is not held_qd:
            self._frames_result = self._frames(q_all, qd_all)
            self._frames_state = (q_all, qd_all)
        return self._frames_result

    def hub_height(self) -> float:
        """Height of the rotor apex above the ground at rest [m]."""
        q_all, qd_all, _ = self.eq.full_state(np.zeros_like(self.q0), np.zeros_like(self.qd0), 0.0)
        states = self.eq.kinematics(q_all, qd_all)
        return float(states[self.eq.body_index["hub"]].r[2])

    def loads(self, t, q_all, qd_all):
        """(generalised forces (n_all,), node forces {body: (N,3)}) of all
        switched-on effects at one state (all coordinates)."""
        gen = np.zeros(self.eq.n_all)
        if len(self._lin_rows):
            np.subtract.at(gen, self._lin_rows, self._lin_k * q_all[self._lin_cols]
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

    def rhs(self):
        """The right-hand side for `integrate`: compiled when no effect acts
        at every step, else `M_F`."""
        if not self.acting and hasattr(self.eq, "compiled_rhs"):
            return self.eq.compiled_rhs(self.linear)
        return self.M_F


def effective_modeset(scene: Scene, modeset: ModeSet | None) -> ModeSet:
    """The scene's active fields, with shapes from `modeset` where it has them."""
    if modeset is None:
        return scene.modes
    fields = {f: modeset[f] if f in modeset else scene.modes[f] for f in scene.fields}
    return ModeSet(fields)


def build(scene: Scene, modeset: ModeSet | None = None, *, reactions: bool = False) -> Built:
    """Equations and effects of `scene` (with `modeset` overriding its
    shapes). reactions: add the reaction coordinates of the load outputs
    (TwrBsMyt, RootMyc<b>; model/template.py)."""
    ms = effective_modeset(scene, modeset)
    init = scene.initial
    effects = select_effects(scene)
    spec = BuildSpec(free=list(scene.free), fixed=dict(scene.fixed), prescribed={},
                     pitch=_collective(init.get("BlPitch", 0.0)), damping=False, reactions=reactions)
    if "GeAz" in scene.constant_speed:
        spec.prescribed["GeAz"] = Prescribed(init.get("Azimuth", 0.0), scene.constant_speed["GeAz"])
    for e in effects:
        e.configure(spec)
    if "GeAz" not in spec.free and "GeAz" not in spec.prescribed:
        spec.fixed.setdefault("GeAz", init.get("Azimuth", 0.0))
    model = build_turbine(scene.turbine, ms, free=spec.free, fixed=spec.fixed, prescribed=spec.prescribed,
                          gravity=bool(scene.effect("gravity")),
                          geometric_stiffening=bool(scene.effect("geometric_stiffening")),
                          rotor_speed_for_shapes=scene.constant_speed.get("GeAz", init.get("RotSpeed", 0.0)),
                          pitch=spec.pitch, drivetrain=spec.drivetrain, gearbox_inertia=spec.gearbox_inertia,
                          reactions=spec.reactions)
    if not spec.damping:
        for b in model.system.flexible_bodies():
            if b.damping is not None:
                b.damping = np.zeros_like(b.damping)
    for e in effects:
        e.prepare(model)
    eq = KaneEquations(model.system)
    q0, qd0 = _initial_state(model, init)
    built = Built(scene, model, eq, q0, qd0, effects)
    for e in effects:
        e.setup(built)
    built._set_linear([term for e in effects for term in e.linear(built)])
    if init.get("equilibrium"):
        built.q0 = static_equilibrium(built)
    return built


def _initial_state(model, init):
    """(q0, qd0) of the free coordinates from ElastoDyn-named initial conditions."""
    names = list(model.system.free)
    q0 = np.zeros(len(names))
    qd0 = np.zeros(len(names))
    pos = {n: i for i, n in enumerate(names)}

    def put(name, value, rate=None):
        if name in pos:
            q0[pos[name]] = value
            if rate is not None:
                qd0[pos[name]] = rate

    fd = model.field_dofs
    if fd.get("tower_fa"):
        put(fd["tower_fa"][0], init.get("TTDspFA", 0.0))
    if fd.get("tower_ss"):
        put(fd["tower_ss"][0], -init.get("TTDspSS", 0.0))       # ElastoDyn: Q_TSS along -y
    if fd.get("tower_torsion"):
        put(fd["tower_torsion"][0], init.get("TTDspTwst", 0.0))
    for dofs in fd.get("blade_flap", []):
        put(dofs[0], init.get("OoPDefl", 0.0))
    for dofs in fd.get("blade_edge", []):
        put(dofs[0], init.get("IPDefl", 0.0))
    put("GeAz", init.get("Azimuth", 0.0), init.get("RotSpeed", 0.0))
    put("Yaw", init.get("NacYaw", 0.0))
    put("PtfmSurge", init.get("PtfmSurge", 0.0))
    put("PtfmPitch", init.get("PtfmPitch", 0.0))
    return q0, qd0


def static_equilibrium(built: Built, t: float = 0.0) -> np.ndarray:
    """Free coordinates at which the elastic and drivetrain coordinates have
    no acceleration (rigid DOFs and all rates as in the initial state): the
    deflection under gravity, centrifugal and aerodynamic loads at t.
    Starting a simulation there removes most of the start-up transient."""
    import scipy.optimize
    names = built.model.system.free
    rigid = {"GeAz", "Yaw", "PtfmSurge", "PtfmPitch"}
    sel = np.array([i for i, n in enumerate(names) if n not in rigid or n in DRIVETRAIN_DOFS], dtype=int)
    if not len(sel):
        return built.q0.copy()

    def residual(x):
        q = built.q0.copy()
        q[sel] = x
        M, F = built.M_F(t, q, built.qd0)
        return np.linalg.solve(M, F)[sel]

    sol = scipy.optimize.root(residual, built.q0[sel], method="hybr", options={"xtol": 1e-10})
    if not sol.success or not np.all(np.isfinite(sol.x)):
        raise ModeselError(f"no static equilibrium found ({sol.message})", file=built.scene.path,
                           field="initial.equilibrium")
    q = built.q0.copy()
    q[sel] = sol.x
    return q


def _collective(pitch) -> float:
    """Collective pitch [rad] from a scalar or per-blade values (their mean)."""
    return float(np.mean(np.atleast_1d(pitch)))


#: units of the output channels (outputs.py), OpenFAST's
_CHANNEL_UNITS = (
    (r"Time", "s"), (r"Azimuth|TTDspTwst|PtfmPitch|NacYaw", "deg"), (r"RotSpeed|GenSpeed", "rpm"),
    (r"TTDsp(FA|SS)|OoPDefl\d|IPDefl\d|TipD[xyz]c\d|PtfmSurge", "m"), (r"RotThrust", "kN"),
    (r"RotTorq|LSShftTq|HSShftTq|GenTq|TwrBsM[xy]t|RootM[xy]c\d", "kN-m"), (r"GenPwr|RotPwr", "kW"),
    (r"BldPitch\d", "deg"), (r"RtAeroFxh", "N"), (r"RtAeroMxh", "N-m"), (r"RtAeroPwr", "W"), (r"RtAeroCp", "-"),
    (r"Q_(TFA|TSS|B\d[FE])\d+|Q_PtfmSurge", "m"), (r"Q_(TTor\d+|GeAz|DrTr|HSSTw|Yaw|PtfmPitch)", "rad"),
    (r"QD_(TFA|TSS|B\d[FE])\d+|QD_PtfmSurge", "m/s"), (r"QD_(TTor\d+|GeAz|DrTr|HSSTw|Yaw|PtfmPitch)", "rad/s"),
)


def channel_unit(name: str) -> str | None:
    """Unit of a simulation output channel (OpenFAST's), None if unknown."""
    return next((unit for pattern, unit in _CHANNEL_UNITS if re.fullmatch(pattern, name)), None)


def _name(built: Built, index: str) -> str:
    names = built.model.system.free
    i = int(index)
    return names[i] if 0 <= i < len(names) else index


def _bounds(built: Built) -> np.ndarray:
    """Physical bounds of |q| for divergence detection: half the beam
    length for elastic tip-normalised coordinates, 1e6 rad for angles."""
    t = built.model.turbine
    out = []
    for n in built.model.system.free:
        if n.startswith(("TFA", "TSS")):
            out.append(0.5 * t.tower.length)
        elif n.startswith("TTor"):
            out.append(np.pi)
        elif n.startswith("B"):
            out.append(0.5 * t.blade.length)
        elif n == "PtfmSurge":
            out.append(1e3)
        else:
            out.append(1e6)
    return np.array(out)


def simulate(scene: Scene, modeset: ModeSet | None = None, *, tmax: float | None = None,
             dt: float | None = None) -> SimulationResult:
    """Integrate `scene` (with `modeset` overriding its shapes) and return outputs."""
    tmax = scene.tmax if tmax is None else float(tmax)
    dt = scene.dt if dt is None else float(dt)
    if tmax <= 0 or dt <= 0:
        raise ModeselError("tmax and dt must be positive", field="tmax/dt")
    t0 = time.perf_counter()
    built = build(scene, modeset, reactions=True)
    requested = scene.solver.get("method", "auto")
    n = len(built.q0)
    if n == 0:
        raise ModeselError("the scene has no free degree of freedom", file=scene.path, field="dofs")
    lin = _lin.linearize(built.M_F, built.q0 * 0, built.qd0, built.model.system.free)
    if not all(np.all(np.isfinite(a)) for a in (lin.M, lin.C, lin.K)):
        raise ModeselError("the equations are not finite at the initial state (check the turbine's "
                           "properties and the scene's parameters)", file=scene.path)
    if scene.solver.get("stability_check", True):
        check_static_stability(lin, file=scene.path, fields=_coordinate_fields(built))
    # oscillatory modes only: a free rotor's speed mode is real (non-oscillating)
    omegas = np.array([2 * np.pi * m.frequency_hz for m in _lin.modes(lin) if abs(m.damping_ratio) < 1.0])
    method, ratio = choose_method(omegas if len(omegas) else np.array([1.0]), requested)
    try:
        integ = integrate(built.rhs(), built.q0, built.qd0, tmax, dt, method=method,
                          rtol=float(scene.solver.get("rtol", 1e-8)), atol=scene.solver.get("atol"),
                          max_step=float(scene.solver.get("max_step", np.inf)), bounds=_bounds(built),
                          stiffness_ratio=ratio)
    except SimulationDiverged as exc:     # name the coordinate and the scene
        reason = re.sub(r"coordinate (\d+) ", lambda m: f"coordinate {_name(built, m.group(1))} ", exc.reason)
        raise SimulationDiverged(reason, exc.time, file=scene.path) from None
    wall = time.perf_counter() - t0
    df = channels(built, integ)
    df.attrs["units"] = {c: u for c in df.columns if (u := channel_unit(c)) is not None}
    return SimulationResult(df, n, wall, float(integ.t[-1]), list(built.model.system.free), method, ratio,
                            integ.n_rhs)


def _coordinate_fields(built: Built) -> dict:
    """{coordinate: what it is} for messages: the field of an elastic
    coordinate, 'drivetrain' for DrTr/HSSTw."""
    out = {d: "drivetrain" for d in DRIVETRAIN_DOFS}
    for fld, dofs in built.model.field_dofs.items():
        groups = dofs if dofs and isinstance(dofs[0], tuple) else [dofs]
        for group in groups:
            out.update({d: fld for d in group})
    return out


def check_static_stability(lin, *, file=None, fields=None) -> None:
    """Raise `PhysicallyUnstable` when the linearised model has a statically
    unstable elastic mode: a real positive eigenvalue lambda of the
    first-order system [[0, I], [-M^-1 K, -M^-1 C]] (a negative effective
    stiffness: no damping can hold it, only gyroscopic coupling could, and
    that would make the eigenvalue complex), whose eigenvector is dominated
    (largest kinetic-energy share |phi_i|^2 M_ii, as `linearize.modes`) by an
    elastic or drivetrain coordinate. Zero-frequency and drifting rigid-body
    modes (free rotor, yaw, platform: RIGID_BODY_DOFS) are not flagged, nor
    real eigenvalues within round-off of zero (STABILITY_NOISE)."""
    n = len(lin.names)
    if n == 0:
        return
    import scipy.linalg
    Minv_K = np.linalg.solve(lin.M, lin.K)
    Minv_C = np.linalg.solve(lin.M, lin.C)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv_K, -Minv_C]])
    lam, vec = scipy.linalg.eig(A)
    noise = STABILITY_NOISE * float(np.abs(lam).max()) + 1e-6
    diag = np.abs(np.diag(lin.M))
    worst = None
    for i in np.flatnonzero((lam.real > noise) & (np.abs(lam.imag) <= noise)):
        label = lin.names[int(np.argmax(np.abs(vec[:n, i]) ** 2 * diag))]
        if label in RIGID_BODY_DOFS:
            continue
        if worst is None or lam[i].real > worst[1]:
            worst = (label, float(lam[i].real))
    if worst is not None:
        what = (fields or {}).get(worst[0])
        raise PhysicallyUnstable(f"{what} ({worst[0]})" if what else worst[0], worst[1], file=file,
                                 detail="e.g. a tower-top mass beyond the buckling load; check the "
                                        "masses and stiffnesses (or set [solver] stability_check = false "
                                        "to simulate it anyway)")


# ------------------------------------------------------------------ linearisation
def linearize_scene(scene: Scene, modeset: ModeSet | None = None, rpm: float | None = None):
    """Modes of the scene linearised at its initial state with zero elastic
    deflection; with `rpm` the rotor turns at that constant speed.

    A three-bladed rotor on a flexible support (tower, yaw or platform DOFs)
    is analysed in multi-blade coordinates (Coleman/MBC, Bir 2008,
    NREL/CP-500-42553): each blade DOF type X (F1, E1, ...) becomes X_coll,
    X_cos, X_sin, the transformed matrices are averaged over MBC_AZIMUTHS
    rotor azimuths (a single one when the rotor is parked), and modes are
    labelled by their dominant MBC coordinate, frequencies being those seen
    in the fixed frame (Campbell diagram). For a parked rotor with blade 1 up,
    X_cos is the rotor "pitch" (tilt) asymmetric mode of flap and the "yaw"
    one of edge, X_sin the flap "yaw" and edge "pitch" modes (Jonkman 2009
    Table 9-1 naming). Otherwise (rotor on a rigid support) the blades are
    analysed in the rotating frame and labelled by their own DOF (B1F1 ...).
    Returns (modes, LinearModel)."""
    if rpm is not None:
        scene = replace(scene, constant_speed={"GeAz": rpm * np.pi / 30.0},
                        free=tuple(d for d in scene.free if d != "GeAz"))
    built = build(scene, modeset)
    names = list(built.model.system.free)
    qd0 = _rigid_rates(built)
    groups = _blade_groups(built)
    if groups is None:
        lin = _lin.linearize(built.M_F, np.zeros_like(built.q0), qd0, names)
        return _lin.modes(lin), lin
    lin = _multiblade(built, groups, qd0)
    return _lin.modes(lin), lin


def _rigid_rates(built):
    out = np.zeros(len(built.q0))
    for i, n in enumerate(built.model.system.free):
        if n == "GeAz":
            out[i] = built.qd0[i]
    return out


def _blade_groups(built):
    """{DOF type: [index of blade 1, 2, 3]} when MBC applies, else None."""
    model = built.model
    names = list(model.system.free)
    if model.turbine.num_blades != 3:
        return None
    support = [n for n in names if n.startswith(("TFA", "TSS", "TTor")) or n in ("Yaw", "PtfmSurge", "PtfmPitch")]
    groups = {}
    for i, n in enumerate(names):
        if n.startswith("B") and n[1].isdigit():
            groups.setdefault(n[2:], [None] * 3)[int(n[1]) - 1] = i
    if not support or not groups:
        return None
    return groups


def _rotor_speed(built, qd0):
    sys = built.model.system
    if "GeAz" in sys.prescribed:
        return float(sys.prescribed["GeAz"].rate)
    if "GeAz" in sys.free:
        return float(qd0[sys.free.index("GeAz")])
    return 0.0


def _multiblade(built, groups, qd0):
    """Linear model in multi-blade coordinates, averaged over azimuths."""
    sys = built.model.system
    names = list(sys.free)
    n = len(names)
    omega = _rotor_speed(built, qd0)
    az0 = built.scene.initial.get("Azimuth", 0.0)
    prescribed = "GeAz" in sys.prescribed
    free_geaz = names.index("GeAz") if "GeAz" in sys.free else None
    count = MBC_AZIMUTHS if (omega != 0.0 and (prescribed or free_geaz is not None)) else 1
    mbc_names = list(names)
    for key, idx in groups.items():
        mbc_names[idx[0]], mbc_names[idx[1]], mbc_names[idx[2]] = f"{key}_coll", f"{key}_cos", f"{key}_sin"
    MB = np.zeros((n, n))
    CB = np.zeros((n, n))
    KB = np.zeros((n, n))
    for k in range(count):
        psi = az0 + 2.0 * np.pi * k / count
        q0 = np.zeros(n)
        t = 0.0
        if count > 1 and prescribed:
            t = (psi - az0) / omega
        elif count > 1:
            q0[free_geaz] = psi
        lin = _lin.linearize(built.M_F, q0, qd0, names, t=t)
        T1, T2, T3 = _mbc_matrices(n, groups, psi)
        Ti = np.linalg.inv(T1)
        MB += Ti @ lin.M @ T1
        CB += Ti @ (2.0 * omega * lin.M @ T2 + lin.C @ T1)
        KB += Ti @ (omega**2 * lin.M @ T3 + omega * lin.C @ T2 + lin.K @ T1)
    return _lin.LinearModel(mbc_names, MB / count, CB / count, KB / count)


def _mbc_matrices(n, groups, psi):
    """q_rot = T1 q_mbc and its first/second azimuth derivatives (Bir 2008):
    blade b's DOF = coll + cos(psi_b) cos + sin(psi_b) sin,
    psi_b = psi + 2 pi (b - 1) / 3."""
    T1 = np.eye(n)
    T2 = np.zeros((n, n))
    T3 = np.zeros((n, n))
    for idx in groups.values():
        c0, cc, cs = idx
        for b, i in enumerate(idx):
            pb = psi + 2.0 * np.pi * b / 3.0
            c, s = np.cos(pb), np.sin(pb)
            T1[i, :] = 0.0
            T1[i, c0], T1[i, cc], T1[i, cs] = 1.0, c, s
            T2[i, cc], T2[i, cs] = -s, c
            T3[i, cc], T3[i, cs] = -c, -s
    return T1, T2, T3
