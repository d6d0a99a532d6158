"""Front functions of the simulator: `load_scene`, `build`, `simulate`,
`linearize_scene`. A scene switches on only the DOFs and effects it calls
for: fields without modes have no states, and an effect that is off is
never evaluated.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from modesel.errors import ModeselError
from modesel.modeset import ModeSet
from modesel.surrogate_sim import linearize as _lin
from modesel.surrogate_sim.equations import KaneEquations
from modesel.surrogate_sim.integrate import choose_method, integrate
from modesel.surrogate_sim.models import build_turbine
from modesel.surrogate_sim.outputs import channels
from modesel.surrogate_sim.scene import Scene, load_scene  # noqa: F401  (re-export)
from modesel.surrogate_sim.system import Prescribed


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
    """A scene turned into equations, ready to integrate or linearise."""

    scene: Scene
    model: object
    eq: KaneEquations
    q0: np.ndarray
    qd0: np.ndarray
    effects: list

    def M_F(self, t, q, qd):
        gen = None
        if self.effects:
            gen = np.zeros(self.eq.n_all)
            for eff in self.effects:
                eff(self, t, q, qd, gen)
        return self.eq.evaluate(q, qd, t, generalized=gen)


def effective_modeset(scene: Scene, modeset: ModeSet | None) -> ModeSet:
    """The scene's active fields, with shapes from `modeset` where it has them."""
    if modeset is None:
        return scene.modes
    fields = {f: modeset[f] if f in modeset else scene.modes[f] for f in scene.fields}
    return ModeSet(fields)


def _drivetrain(built, t, q, qd, gen):
    """Drivetrain torsional spring and damper on DrTr (ElastoDyn DTTorSpr/DTTorDmp)."""
    eq = built.eq
    i = eq.index.get("DrTr")
    if i is None or "DrTr" not in built.model.system.free:
        return
    q_all, qd_all, _ = eq.full_state(q, qd, t)
    tb = built.model.turbine
    gen[i] -= tb.drivetrain_stiffness * q_all[i] + tb.drivetrain_damping * qd_all[i]


def build(scene: Scene, modeset: ModeSet | None = None) -> Built:
    ms = effective_modeset(scene, modeset)
    init = scene.initial
    prescribed = {}
    fixed = dict(scene.fixed)
    if "GeAz" in scene.constant_speed:
        prescribed["GeAz"] = Prescribed(init.get("Azimuth", 0.0), scene.constant_speed["GeAz"])
    elif "GeAz" not in scene.free:
        fixed.setdefault("GeAz", init.get("Azimuth", 0.0))
    model = build_turbine(scene.turbine, ms, free=scene.free, fixed=fixed, prescribed=prescribed,
                          gravity=bool(scene.effect("gravity")),
                          geometric_stiffening=bool(scene.effect("geometric_stiffening")),
                          rotor_speed_for_shapes=scene.constant_speed.get("GeAz", init.get("RotSpeed", 0.0)),
                          pitch=_collective(init.get("BlPitch", 0.0)))
    if not scene.effect("damping"):
        for b in model.system.flexible_bodies():
            if b.damping is not None:
                b.damping = np.zeros_like(b.damping)
    eq = KaneEquations(model.system)
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
    effects = []
    if "DrTr" in scene.free:
        effects.append(_drivetrain)
    return Built(scene, model, eq, q0, qd0, effects)


def _collective(pitch) -> float:
    """Collective pitch [rad] from a scalar or per-blade values (their mean)."""
    return float(np.mean(np.atleast_1d(pitch)))


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
    built = build(scene, modeset)
    requested = scene.solver.get("method", "auto")
    n = len(built.q0)
    if n == 0:
        raise ModeselError("the scene has no free degree of freedom", file=scene.path, field="dofs")
    lin = _lin.linearize(built.M_F, built.q0 * 0, built.qd0, built.model.system.free)
    omegas = np.array([2 * np.pi * m.frequency_hz for m in _lin.modes(lin)])
    method, ratio = choose_method(omegas if len(omegas) else np.array([1.0]), requested)
    integ = integrate(built.M_F, built.q0, built.qd0, tmax, dt, method=method,
                      rtol=float(scene.solver.get("rtol", 1e-8)), atol=scene.solver.get("atol"),
                      max_step=float(scene.solver.get("max_step", np.inf)), bounds=_bounds(built),
                      stiffness_ratio=ratio)
    wall = time.perf_counter() - t0
    df = channels(built.model, built.eq, integ)
    return SimulationResult(df, n, wall, float(integ.t[-1]), list(built.model.system.free), method, ratio,
                            integ.n_rhs)


def linearize_scene(scene: Scene, modeset: ModeSet | None = None, rpm: float | None = None):
    """Modes of the scene linearised at its initial state with zero elastic
    deflection; with `rpm` the rotor turns at that constant speed."""
    if rpm is not None:
        scene = Scene(**{**scene.__dict__, "constant_speed": {"GeAz": rpm * np.pi / 30.0},
                         "free": tuple(d for d in scene.free if d != "GeAz")})
    built = build(scene, modeset)
    q0 = np.zeros_like(built.q0)
    lin = _lin.linearize(built.M_F, q0, built.qd0 * 0 + _rigid_rates(built), built.model.system.free)
    return _lin.modes(lin), lin


def _rigid_rates(built):
    out = np.zeros(len(built.q0))
    for i, n in enumerate(built.model.system.free):
        if n == "GeAz":
            out[i] = built.qd0[i]
    return out
