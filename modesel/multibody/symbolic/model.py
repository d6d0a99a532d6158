"""`SymbolicModel`: the symbolic equations M(q) qdd = F(q, qd, t, u) of a
small model, with its parameter values, numeric evaluation (lambdify) and
analytic linearisation; and the front functions `derive` (from a System)
(`modesel.simulation.symbolic.derive_scene` derives a scene, restricted to the small models).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from modesel.errors import ModeselError
from modesel.multibody.symbolic import approximations as approx
from modesel.multibody.symbolic.kane import Derivation, SymbolicKane, coordinate_latex

MAX_DOFS = 9
UNSUPPORTED_EFFECTS = ("aero", "wind", "tower_drag", "generator")


@dataclass
class SymbolicModel:
    """Symbolic equations of motion of one model (first paper eq. 22).

    `M`, `F`: sympy matrices (after the optional small-angle truncation) in
    the symbols `q`, `qd` (free and prescribed coordinates), `qdd` of the
    prescribed coordinates, the parameters (`parameters()`: name -> value,
    SI) and the inputs (f_a thrust [N], tau_a aerodynamic torque [N m]).
    `prescribed`: {name: (value, rate, accel)} with q(t) = value + rate t +
    accel t^2/2 [rad, rad/s, rad/s^2]. `seconds`: timing of each step."""

    name: str
    derivation: Derivation
    M: sp.Matrix
    F: sp.Matrix
    small_angle: dict = field(default_factory=dict)
    prescribed: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    description: str = ""
    _numeric: tuple | None = None

    # ------------------------------------------------------------- symbols
    @property
    def coordinates(self) -> list:
        return list(self.derivation.free)

    @property
    def table(self):
        return self.derivation.table

    def parameters(self) -> dict:
        return self.table.values()

    def q_symbols(self):
        d = self.derivation
        return [d.q[n] for n in d.free]

    def qd_symbols(self):
        d = self.derivation
        return [d.qd[n] for n in d.free]

    def prescribed_symbols(self):
        d = self.derivation
        return ([d.q[n] for n in d.prescribed], [d.qd[n] for n in d.prescribed],
                [d.qdd[n] for n in d.prescribed])

    def arguments(self) -> list:
        """Order of the arguments of the lambdified functions."""
        pq, pqd, pqdd = self.prescribed_symbols()
        return (self.q_symbols() + self.qd_symbols() + pq + pqd + pqdd + self.table.symbols()
                + list(self.derivation.inputs))

    def latex_names(self) -> dict:
        d = self.derivation
        names = dict(self.table.latex_names())
        for n in d.q:
            base = coordinate_latex(n)
            head, sep, sub = base.partition("_")          # q_{TFA1} -> \dot{q}_{TFA1}
            names[d.q[n]] = base
            names[d.qd[n]] = rf"\dot{{{head}}}{sep}{sub}"
            names[d.qdd[n]] = rf"\ddot{{{head}}}{sep}{sub}"
        for u, lat in zip(d.inputs, (r"f_a", r"\tau_a")):
            names[u] = lat
        return names

    def prescribed_state(self, t: float):
        """Values, rates and accelerations of the prescribed coordinates at t [s]."""
        q, qd, qdd = [], [], []
        for n in self.derivation.prescribed:
            v, r, a = self.prescribed[n]
            q.append(v + r * t + 0.5 * a * t * t)
            qd.append(r + a * t)
            qdd.append(a)
        return q, qd, qdd

    # ------------------------------------------------------------- numeric
    def _functions(self):
        if self._numeric is None:
            args = self.arguments()
            self._numeric = (sp.lambdify(args, self.M, modules="numpy", cse=True),
                             sp.lambdify(args, self.F, modules="numpy", cse=True))
        return self._numeric

    def _args(self, q, qd, t, p, u):
        values = self.parameters()
        if p:
            unknown = set(p) - set(values)
            if unknown:
                raise ModeselError(f"unknown parameter(s) {sorted(unknown)}", field="parameters")
            values.update(p)
        u = [0.0] * len(self.derivation.inputs) if u is None else list(u)
        pq, pqd, pqdd = self.prescribed_state(t)
        return list(q) + list(qd) + pq + pqd + pqdd + list(values.values()) + u

    def evaluate(self, q, qd, t: float = 0.0, p: dict | None = None, u=None):
        """Numeric (M, F) at free coordinates q, rates qd, time t [s];
        `p` overrides parameter values, `u` = (f_a, tau_a)."""
        fM, fF = self._functions()
        a = self._args(q, qd, t, p, u)
        return np.array(fM(*a), float), np.array(fF(*a), float).ravel()

    def with_small_angles(self, small_angle) -> "SymbolicModel":
        """A copy of the exact model with the small-angle truncation applied
        (spec as in approximations.parse_orders)."""
        if self.small_angle:
            raise ModeselError("small angles are applied to the exact model only", field="small-angle")
        orders = approx.parse_orders(small_angle)
        start = time.perf_counter()
        d = self.derivation
        groups = {"tilt": d.table.group("tilt"), "slope": d.table.group("slope"),
                  "pitch": [d.q[n] for n in ("PtfmPitch",) if n in d.free]}
        M = approx.small_angle(self.M, groups, orders)
        F = approx.small_angle(self.F, groups, orders)
        seconds = {**self.seconds, "small_angle": time.perf_counter() - start}
        return SymbolicModel(self.name, d, M, F, orders, dict(self.prescribed), seconds, self.description)

    def with_prescribed(self, motion: dict) -> "SymbolicModel":
        """A copy with other prescribed motions {name: (value, rate, accel)}
        (e.g. the parked rotor); the equations are unchanged."""
        unknown = set(motion) - set(self.prescribed)
        if unknown:
            raise ModeselError(f"not prescribed coordinates: {sorted(unknown)}", field="prescribed")
        return SymbolicModel(self.name, self.derivation, self.M, self.F, dict(self.small_angle),
                             {**self.prescribed, **motion}, dict(self.seconds), self.description)

    # ------------------------------------------------------- linearisation
    def linearize(self, q0=None, qd0=None) -> approx.LinearSymbolic:
        """Symbolic M0, C0, K0, Q0 (eq. 23-25) at q0, qd0 (default 0); the
        parameters and prescribed coordinates stay symbolic."""
        q, qdot = self.q_symbols(), self.qd_symbols()
        q0 = np.zeros(len(q)) if q0 is None else np.asarray(q0, float)
        qd0 = np.zeros(len(q)) if qd0 is None else np.asarray(qd0, float)
        point = {**{s: sp.Float(v) if v else sp.Integer(0) for s, v in zip(q, q0)},
                 **{s: sp.Float(v) if v else sp.Integer(0) for s, v in zip(qdot, qd0)}}
        return approx.linearize(self.M, self.F, q, qdot, self.derivation.inputs, point)

    def linear_matrices(self, q0=None, qd0=None, t: float = 0.0, p: dict | None = None):
        """Numeric (M0, C0, K0) at q0, qd0 (default 0) and time t."""
        lin = self.linearize(q0, qd0)
        args = self.arguments()
        values = self._args(np.zeros(len(self.coordinates)), np.zeros(len(self.coordinates)), t, p, None)
        out = []
        for X in (lin.M0, lin.C0, lin.K0):
            f = sp.lambdify(args, X, modules="numpy", cse=True)
            out.append(np.array(f(*values), float))
        return tuple(out)


def derive(system, *, name: str = "model", small_angle=None, inputs: bool = True, springs=None,
           description: str = "") -> SymbolicModel:
    """Symbolic equations of `system` (a `System` of bodies.py).

    small_angle: None, an order for tilt and slopes, or {group: order}
    (groups 'tilt', 'slope', 'pitch'; see approximations.py).
    springs: {coordinate: (k, c)} linear spring-dampers (drivetrain)."""
    for n, pr in system.prescribed.items():
        if pr.function is not None:
            raise ModeselError(f"prescribed coordinate '{n}' is a function of time; the symbolic layer "
                               "supports value + rate t + accel t^2/2 only", field=n)
    orders = approx.parse_orders(small_angle)
    der = SymbolicKane(system, inputs=inputs, springs=springs).derive()
    prescribed = {n: (float(p.value), float(p.rate), float(p.accel)) for n, p in system.prescribed.items()}
    model = SymbolicModel(name, der, der.M, der.F, {}, prescribed, {"derive": der.seconds}, description)
    return model.with_small_angles(orders) if orders else model
