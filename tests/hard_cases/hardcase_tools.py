"""Shared tools of the hard-case suite: scenes built from the bundled ones,
an energy balance over a simulation, engine frequencies, and the check that
the integrator's choice follows the stiffness it detects.

Every hard case checks that the run finishes with finite results, that the
energy is conserved when it should be (modesel.multibody.energy: no
damping, no external force, no prescribed motion), that the engine's
frequencies agree with a finer reference, and that the explicit (DOP853) /
implicit (compiled-Radau or scipy's Radau) choice matches the stiffness ratio (integrate.choose_method).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from modesel.modeset import FieldModes, ModeSet
from modesel.simulation import api
from modesel.multibody import linearize as lin
from modesel.multibody.energy import total_energy
from modesel.multibody.integrate import explicit_method, runs_compiled

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "studies" / "scenes"
#: integrate.choose_method: explicit below this stiffness ratio, implicit from
#: it on (the documented rule, docs/benchmarks.md, "Stiff and large systems"; written here
#: so that a change of the rule shows in the hard cases)
STIFF_RATIO = 80.0


def scene(name: str, **changes):
    """A bundled scene (studies/scenes/<name>.toml), deep-copied, with
    attributes replaced (e.g. modes=ModeSet(...), effects={...})."""
    sc = copy.deepcopy(api.load_scene(SCENES / f"{name}.toml"))
    for key, value in changes.items():
        setattr(sc, key, value)
    return sc


def modes(**fields) -> ModeSet:
    """ModeSet from field=(family, count[, params])."""
    return ModeSet({f: FieldModes(spec[0], spec[1], dict(spec[2]) if len(spec) > 2 else {})
                    for f, spec in fields.items()})


def conservative(sc):
    """`sc` with damping off and only gravity (no effect doing work); the
    scene's kinematic flags (geometric stiffening, structural twist) kept."""
    sc.effects = {"gravity": bool(sc.effects.get("gravity", True)),
                  "geometric_stiffening": bool(sc.effects.get("geometric_stiffening", True)),
                  "structural_twist": bool(sc.effects.get("structural_twist", True)),
                  "damping": False}
    assert not sc.constant_speed, "prescribed motion does work: energy is not conserved"
    return sc


@dataclass
class Run:
    result: object           # api.SimulationResult
    built: object            # api.Built of the same scene and mode set
    q: np.ndarray
    qd: np.ndarray

    @property
    def method(self) -> str:
        return self.result.method

    @property
    def ratio(self) -> float:
        return self.result.stiffness_ratio

    def finite(self) -> bool:
        return bool(np.all(np.isfinite(self.result.outputs.to_numpy(dtype=float))))

    def energy(self, stride: int = 1) -> np.ndarray:
        return np.array([energy(self.built, q, qd) for q, qd in zip(self.q[::stride], self.qd[::stride])])

    def kinetic(self, stride: int = 1) -> np.ndarray:
        return np.array([kinetic_energy(self.built, q, qd) for q, qd in zip(self.q[::stride], self.qd[::stride])])

    def energy_drift(self, stride: int = 1) -> float:
        """max |E(t) - E(0)| over the energy exchanged between the kinetic and
        potential forms, max |T(t) - T(0)| (a scale that needs no rest state:
        near buckling the undeflected state is not an energy minimum)."""
        e, k = self.energy(stride), self.kinetic(stride)
        exchanged = float(np.max(np.abs(k - k[0])))
        assert exchanged > 0, "nothing moved: the energy balance would check nothing"
        return float(np.max(np.abs(e - e[0])) / exchanged)


def energy(built, q, qd) -> float:
    """energy.total_energy plus the potential of the effects' linear springs
    (drivetrain: Q_r = -sum_c k_rc q_c, so V = 1/2 sum k_rc q_r q_c), which
    total_energy leaves out."""
    q_all, _, _ = built.eq.full_state(q, qd, 0.0)
    springs = 0.5 * float(np.sum(built._lin_k * q_all[built._lin_rows] * q_all[built._lin_cols]))
    return total_energy(built, q, qd) + springs


def kinetic_energy(built, q, qd) -> float:
    M, _ = built.eq.evaluate(q, qd, 0.0)
    return float(0.5 * qd @ M @ qd)


def simulate(sc, ms=None, **kw) -> Run:
    result = api.simulate(sc, ms, **kw)
    built = api.build(sc, ms)
    names = built.model.system.free
    out = result.outputs
    q = out[[f"Q_{n}" for n in names]].to_numpy(dtype=float)
    qd = out[[f"QD_{n}" for n in names]].to_numpy(dtype=float)
    return Run(result, built, q, qd)


def frequencies(sc, ms=None, rpm=None, prefix=None) -> np.ndarray:
    """Distinct natural frequencies [Hz] of the linearised scene (modes whose
    label starts with `prefix`), repeated eigenvalues (identical blades)
    counted once."""
    found, _ = api.linearize_scene(sc, ms, rpm=rpm)
    f = sorted(m.frequency_hz for m in found if prefix is None or m.label.startswith(prefix))
    out = []
    for x in f:
        if not out or x > out[-1] * (1 + 1e-7):
            out.append(x)
    return np.array(out)


def detected_ratio(sc, ms=None) -> float:
    """Stiffness ratio recomputed independently of api.simulate: highest over
    lowest oscillatory natural frequency of the scene linearised at rest."""
    built = api.build(sc, ms)
    model = lin.linearize(built.M_F, np.zeros_like(built.q0), built.qd0, built.model.system.free)
    w = np.array([m.frequency_hz for m in lin.modes(model) if abs(m.damping_ratio) < 1.0])
    return float(w.max() / w.min())


def assert_method_justified(run: Run, sc, ms=None) -> None:
    """The integrator is explicit for a non-stiff system and implicit for a
    stiff one, and the ratio it acted on is the scene's."""
    ratio = detected_ratio(sc, ms)
    assert run.ratio == np.float64(run.ratio) and abs(run.ratio / ratio - 1) < 1e-6, (run.ratio, ratio)
    compiled = runs_compiled(run.built.rhs())
    explicit = explicit_method(sc.solver.get("rtol"), compiled, kinked=run.built.kinked)
    implicit = "compiled-Radau" if compiled else "Radau"
    assert run.method == (implicit if ratio >= STIFF_RATIO else explicit), (run.method, ratio)
