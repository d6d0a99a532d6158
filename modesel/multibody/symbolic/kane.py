"""Symbolic Kane equations of a `System` (first paper section 2, eq. 4-22).

The same data objects as the numeric engine (`bodies.py`, `system.py`) are
turned into a `sympy.physics.mechanics` model: one ReferenceFrame per joint
rotation (`orient_axis`, pre-rotations decomposed into body-fixed x-y-z
angles), one Point per body origin (`locatenew` with the joint offset,
elastic translation and axial shortening), velocities and accelerations by
differentiation in the inertial frame. Every constant is a symbol of a
`ParameterTable` (its numeric value is the engine's). Then Kane's method:

    e_r = sum_bodies  J_v,r . (f + f*) + J_w,r . (tau + tau*) + J_e,r . (h + h*) = 0   (eq. 4-5, 7, 9, 18-19)

rigid bodies with eq. 6-9, flexible bodies with the point-wise form of
eq. 11-19 summed over the body through its shape integrals
(`shape_integrals.py`). Finally M = -de/dqdd and F = e(qdd = 0) (eq. 21-22).
Vectors are expressed in the body frame of each body before the dot
products (Appendix A writes all flexible-body terms in the body frame).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import sympy as sp
from sympy.physics.mechanics import Point, ReferenceFrame, dynamicsymbols, msubs

from modesel.errors import ModeselError
from modesel.multibody.bodies import FlexibleBody, RigidBody
from modesel.multibody.lumping import joint_coordinates
from modesel.multibody.rotations import elementary_rotation
from modesel.multibody.symbolic.parameters import (AXES, SMALL_PRE_ROTATION, ParameterTable,
                                                       body_label)
from modesel.multibody.symbolic.reduction import reduce_system
from modesel.multibody.symbolic.shape_integrals import NodeField, ShapeIntegrals, body_key, constant

COORDINATE_LATEX = {"GeAz": r"\psi", "PtfmSurge": r"x", "PtfmPitch": r"\phi_y", "Yaw": r"\theta_{yaw}",
                    "DrTr": r"\theta_{DT}"}
# paper names for constants the turbine template uses (first paper section 4.4)
PREFERRED = {
    ("pre", "hub", "y"): ("theta_t", r"\theta_t", "shaft tilt (rotation of the shaft about y)"),
    ("coeff", "generator", "GeAz"): ("n_gb", r"n_{gb}", "gearbox ratio"),
}
REL_ZERO = 1e-10     # rigid-body cm/inertia entries below this fraction of the largest are exact zeros


def coordinate_latex(name: str) -> str:
    return COORDINATE_LATEX.get(name, f"q_{{{name}}}")


def xyz_angles(R: np.ndarray):
    """(a, b, c) with R = Rx(a) Ry(b) Rz(c) (body-fixed x-y-z sequence)."""
    b = float(np.arcsin(np.clip(R[0, 2], -1.0, 1.0)))
    c = float(np.arctan2(-R[0, 1], R[0, 0]))
    a = float(np.arctan2(-R[1, 2], R[2, 2]))
    back = elementary_rotation(0, a) @ elementary_rotation(1, b) @ elementary_rotation(2, c)
    if not np.allclose(back, R, rtol=0, atol=1e-12):
        raise ModeselError("a joint pre-rotation is not decomposable into x-y-z angles (gimbal lock)")
    return a, b, c


@dataclass
class Derivation:
    """Result of the symbolic Kane method: M(q) qdd = F(q, qd, t, u).

    `q`, `qd`, `qdd`: {coordinate: Symbol} for free and prescribed
    coordinates (prescribed ones are known functions of time). `inputs`:
    symbols of external inputs (rotor thrust f_a along the shaft and
    aerodynamic torque tau_a, first paper Fig. 4). `lumped`: bodies merged
    into rigid bodies (reduction.py)."""

    free: list
    prescribed: list
    q: dict
    qd: dict
    qdd: dict
    M: sp.Matrix
    F: sp.Matrix
    table: ParameterTable
    inputs: list = field(default_factory=list)
    lumped: dict = field(default_factory=dict)
    seconds: float = 0.0


class SymbolicKane:
    """Method object: `SymbolicKane(system).derive()` -> Derivation.

    inputs: add thrust/torque input symbols acting on the hub (shaft axis).
    springs: {coordinate: (k [N m/rad or N/m], c [N m s/rad])} linear
    spring-dampers on rigid coordinates (e.g. the drivetrain DrTr)."""

    def __init__(self, system, *, inputs: bool = True, springs: dict | None = None):
        self.system = system
        self.inputs = inputs
        self.springs = dict(springs or {})
        self.table = ParameterTable()
        self.t = dynamicsymbols._t
        self.free = list(system.free)
        self.prescribed = list(system.prescribed)
        self.qt = {n: dynamicsymbols(n) for n in self.free + self.prescribed}
        self.N = ReferenceFrame("N")
        self.O = Point("O")
        self.O.set_vel(self.N, 0)
        self.g = self.table.get("g", system.gravity, "g", "acceleration of gravity along -z [m/s^2]")
        self.input_symbols = []

    # ----------------------------------------------------------- constants
    def coordinate(self, name):
        if name in self.qt:
            return self.qt[name]
        value = float(self.system.fixed.get(name, 0.0))
        return self.table.get(f"{name}_0", value, f"{coordinate_latex(name)}_0", f"fixed value of {name}")

    def _named(self, key, default):
        return PREFERRED.get(key, default)

    # ---------------------------------------------------------- kinematics
    def _frames(self, body, parent_frame, parent_flexible, parent_dofs, label):
        """Frame of `body`: pre-rotation angles, then the joint's rotations
        (a tip slope nu of a flexible parent is a 'slope' constant)."""
        j = body.joint
        frame = parent_frame
        k = 0

        def rotate(axis, angle):
            nonlocal frame, k
            if angle == 0:
                return
            k += 1
            new = ReferenceFrame(f"{body.name}{k}")
            new.orient_axis(frame, getattr(frame, AXES[axis]), angle)
            frame = new

        R0 = np.asarray(j.pre_rotation, float)
        if not np.array_equal(R0, np.eye(3)):
            for axis, value in enumerate(xyz_angles(R0)):
                if abs(value) < 1e-15:
                    continue
                ax = AXES[axis]
                name, lat, meaning = self._named(("pre", body.name, ax),
                                                 (f"theta_{ax}{label}", rf"\theta_{{{ax},{label}}}",
                                                  f"constant rotation of {label} about {ax}"))
                small = "tilt" if abs(value) < SMALL_PRE_ROTATION else None
                rotate(axis, self.table.get(name, value, lat, meaning, group=small, share=("pre", ax, value)))
        for rot in j.rotations:
            ax = AXES[rot.axis]
            angle = sp.Integer(0)
            for d, c in rot.coeffs.items():
                qd_ = self.coordinate(d)
                if qd_ == 0:
                    continue
                if parent_flexible and d in parent_dofs:
                    plabel = parent_flexible
                    many = len(rot.coeffs) > 1
                    name = f"nu_{ax}{plabel}" + (f"_{d}" if many else "")
                    lat = rf"\nu_{{{ax},{d if many else plabel}}}"
                    coeff = self.table.get(name, c, lat, f"slope (rotation about {ax}) of the tip of "
                                           f"{plabel} per unit {d}", group="slope")
                else:
                    name, lat, meaning = self._named(("coeff", body.name, d),
                                                     (f"n_{label}{d}", rf"n_{{{label},{d}}}",
                                                      f"rotation of {label} per unit {d}"))
                    coeff = self.table.get(name, c, lat, meaning, exact_units=True)
                angle += coeff * qd_
            angle += self.table.get(f"theta0_{ax}{label}", rot.offset, rf"\theta_{{0,{ax},{label}}}",
                                    f"angle offset of {label} about {ax}")
            rotate(rot.axis, angle)
        return frame

    def _placement(self, body, P, plabel, parent_flexible, label):
        """Vector from the parent origin to the body origin (parent frame, bodies.py)."""
        j = body.joint
        off = np.asarray(j.offset, float)
        vec = 0 * P.x
        if parent_flexible and off[0] == 0.0 and off[1] == 0.0:
            vec += self.table.get(f"L_{plabel}", off[2], f"L_{{{plabel}}}",
                                  f"position of the tip of {plabel} along its axis [m]") * P.z
        else:
            for c in range(3):
                vec += self.table.get(f"{AXES[c]}_{plabel}{label}", off[c], f"{AXES[c]}_{{{plabel}{label}}}",
                                      f"{AXES[c]} of the origin of {label} in the {plabel} frame [m]",
                                      share=("offset", plabel, c, off[c])) * getattr(P, AXES[c])
        for d, t in j.translation.items():
            for c in range(3):
                if parent_flexible:
                    s = self.table.get(f"u_{AXES[c]}{d}", t[c], f"u_{{{AXES[c]},{d}}}",
                                       f"{AXES[c]} tip displacement of {plabel} per unit {d} [m]")
                else:
                    s = self.table.get(f"a_{AXES[c]}{label}{d}", t[c], f"a_{{{AXES[c]},{label}{d}}}",
                                       f"{AXES[c]} translation of {label} per unit {d}", exact_units=True)
                vec += s * self.coordinate(d) * getattr(P, AXES[c])
        if j.shortening is not None:
            sh = j.shortening
            qs = [self.coordinate(d) for d in sh.dofs]
            G = np.asarray(sh.matrix, float)
            quad = 0
            for a in range(len(qs)):
                for b in range(a, len(qs)):
                    g = self.table.get(f"G_{plabel}{a + 1}{b + 1}", G[a, b], f"G_{{{plabel},{a + 1}{b + 1}}}",
                                       f"axial shortening of the tip of {plabel} (int phi'_i.phi'_j ds) [1/m]")
                    quad += g * qs[a] * qs[b] * (1 if a == b else 2)
            axis = sum((self.table.get(f"e_{AXES[c]}{plabel}", sh.axis[c], f"e_{{{AXES[c]},{plabel}}}",
                                       f"shortening axis of {plabel}", exact_units=True)
                        * getattr(P, AXES[c]) for c in range(3)), 0 * P.x)
            vec += -sp.Rational(1, 2) * quad * axis
        return vec

    # ------------------------------------------------------------ assembly
    def _rigid_symbols(self, body, label):
        m = self.table.get(f"M_{label}", body.mass, f"M_{{{label}}}", f"mass of {label} [kg]")
        cm = np.asarray(body.cm, float)
        scale = float(np.max(np.abs(cm))) if np.any(cm) else 0.0
        r = sp.Matrix([0 if abs(cm[c]) <= REL_ZERO * scale else
                       self.table.get(f"{AXES[c]}_{label}G", cm[c], f"{AXES[c]}_{{{label}G}}",
                                      f"{AXES[c]} of the centre of mass of {label} (body frame) [m]")
                       for c in range(3)])
        J = np.asarray(body.inertia, float)
        scale = float(np.max(np.abs(J))) if np.any(J) else 0.0
        I = sp.zeros(3, 3)
        axisym = (abs(J[1, 1] - J[2, 2]) <= REL_ZERO * scale and abs(J[1, 2]) <= REL_ZERO * scale
                  and J[1, 1] != 0)
        for a in range(3):
            for b in range(a, 3):
                if abs(J[a, b]) <= REL_ZERO * scale:
                    continue
                if a == b and a > 0 and axisym:
                    s = self.table.get(f"J_o{label}", 0.5 * (J[1, 1] + J[2, 2]), rf"J_{{\oplus,{label}}}",
                                       f"inertia of {label} about y and z through its cm [kg m^2]")
                else:
                    ax = AXES[a] + ("" if a == b else AXES[b])
                    s = self.table.get(f"J_{ax}{label}", J[a, b], f"J_{{{ax},{label}}}",
                                       f"inertia tensor entry {ax} of {label} about its cm [kg m^2]")
                I[a, b] = I[b, a] = s
        return m, r, I

    def derive(self) -> Derivation:
        start = time.perf_counter()
        reduced = reduce_system(self.system)
        N, t = self.N, self.t
        qd = {n: q.diff(t) for n, q in self.qt.items()}
        free_set = set(self.free)
        frames, points, driven = {}, {}, {}
        flex_labels = {}
        integrals = {}
        e = [sp.Integer(0)] * len(self.free)
        g_vec = -self.g * N.z
        for body in reduced.bodies:
            j = body.joint
            label = body_label(body.name)
            if isinstance(body, FlexibleBody):
                key = body_key(body)
                if key not in integrals:
                    used = {si.label for si in integrals.values()}
                    lab = label if label not in used else body.name
                    integrals[key] = ShapeIntegrals(body, lab, self.table)
                flex_labels[body.name] = integrals[key].label
                label = integrals[key].label
            if j.parent is None:
                P, Op, plabel, pflex, pdriven = N, self.O, "O", None, False
            else:
                P, Op = frames[j.parent], points[j.parent]
                plabel = flex_labels.get(j.parent, body_label(j.parent))
                pflex = flex_labels.get(j.parent)
                pdriven = driven[j.parent]
            pdofs = set(reduced.body(j.parent).dofs) if pflex else set()
            B = self._frames(body, P, pflex, pdofs, label)
            rel = self._placement(body, P, plabel, pflex, label)
            Ob = Op.locatenew(f"O_{body.name}", rel)
            Ob.set_vel(N, Op.vel(N) + rel.dt(N))
            Ob.set_acc(N, Ob.vel(N).dt(N))
            frames[body.name], points[body.name] = B, Ob
            own = joint_coordinates(j) | (set(body.dofs) if isinstance(body, FlexibleBody) else set())
            driven[body.name] = pdriven or bool(own & free_set)
            if not driven[body.name]:
                continue                       # no free coordinate moves it: no contribution
            w = B.ang_vel_in(N).to_matrix(B)
            al = B.ang_acc_in(N).to_matrix(B)
            vO = Ob.vel(N).to_matrix(B)
            aO = Ob.acc(N).to_matrix(B)
            gB = g_vec.to_matrix(B)
            if isinstance(body, RigidBody):
                if body.mass == 0.0 and not np.any(body.inertia):
                    continue
                m, r, I = self._rigid_symbols(body, label)
                vG = vO + w.cross(r)
                aG = aO + al.cross(r) + w.cross(w.cross(r))
                f = m * (gB - aG)                                     # eq. 6 (+ gravity, eq. 9)
                tau = -(I * al + w.cross(I * w))
                for i, n in enumerate(self.free):
                    Jv, Jw = vG.diff(qd[n]), w.diff(qd[n])            # eq. 8
                    e[i] += Jv.dot(f) + Jw.dot(tau)                   # eq. 7, 9
            else:
                e = self._flexible(body, integrals[body_key(body)], w, al, vO, aO, gB, qd, e)
            if self.inputs and body.name == "hub":             # rotor thrust and torque along the shaft x
                self.input_symbols = [sp.Symbol("f_a", real=True), sp.Symbol("tau_a", real=True)]
                f_a, tau_a = self.input_symbols
                for i, n in enumerate(self.free):
                    e[i] += vO.diff(qd[n])[0] * f_a + w.diff(qd[n])[0] * tau_a      # eq. 9
        for i, n in enumerate(self.free):
            if n in self.springs:
                k, c = self.springs[n]
                ks = self.table.get(f"k_{n}", k, f"k_{{{n}}}", f"spring stiffness on {n}")
                cs = self.table.get(f"c_{n}", c, f"c_{{{n}}}", f"damping on {n}")
                e[i] -= ks * self.qt[n] + cs * qd[n]
        return self._split(e, reduced, start)

    def _flexible(self, body, si: ShapeIntegrals, w, al, vO, aO, gB, qd, e):
        """Flexible body: e_r += sum_k m_k dv_k/dqd_r . (g - a_k) - (K q + D qd)_r
        (eq. 3, 12-19, A16-A19, summed through the shape integrals)."""
        t = self.t
        qe = [self.coordinate(d) for d in body.dofs]
        c = si.position_coefficients(qe)
        cd = {b: sp.diff(x, t) for b, x in c.items()}
        cdd = {b: sp.diff(x, t) for b, x in cd.items()}
        s = NodeField.expansion(c)
        sd = NodeField.expansion(cd)
        acc = (constant(aO) + s.crossed(al) + s.crossed(w).crossed(w) + sd.crossed(w).scaled(2)
               + NodeField.expansion(cdd))                               # eq. 3
        load = constant(gB) - acc
        ne = len(qe)
        K = np.zeros((ne, ne)) if body.stiffness is None else np.asarray(body.stiffness, float)
        D = np.zeros((ne, ne)) if body.damping is None else np.asarray(body.damping, float)
        L = si.label
        Ks = sp.Matrix(ne, ne, lambda a, b: self.table.get(
            f"K_e{L}{min(a, b) + 1}{max(a, b) + 1}", K[min(a, b), max(a, b)],
            f"K_{{e,{L}{min(a, b) + 1}{max(a, b) + 1}}}", f"elastic stiffness of {L} (eq. B2) [N/m]"))
        Ds = sp.Matrix(ne, ne, lambda a, b: self.table.get(
            f"D_e{L}{a + 1}{b + 1}", D[a, b], f"D_{{e,{L}{a + 1}{b + 1}}}", f"elastic damping of {L} [N s/m]"))
        qe_d = [sp.diff(x, t) for x in qe]
        h = -(Ks * sp.Matrix(qe) + Ds * sp.Matrix(qe_d))                  # eq. 17, A16
        for i, n in enumerate(self.free):
            Jv, Jw = vO.diff(qd[n]), w.diff(qd[n])
            elastic = {b: sp.diff(x, qd[n]) for b, x in cd.items()}
            if Jv.is_zero_matrix and Jw.is_zero_matrix and not any(x != 0 for x in elastic.values()):
                continue
            partial = constant(Jv) + s.crossed(Jw) + NodeField.expansion(elastic)
            e[i] += si.dot_sum(partial, load)                               # eq. 18-19
            if n in body.dofs:
                e[i] += h[list(body.dofs).index(n)]
        return e

    def _split(self, e, reduced, start) -> Derivation:
        """Plain symbols for q, qd, qdd; M = -de/dqdd, F = e(qdd=0) (eq. 21-22)."""
        t = self.t
        q, qd, qdd, sub = {}, {}, {}, {}
        for n, x in self.qt.items():
            q[n] = sp.Symbol(n, real=True)
            qd[n] = sp.Symbol(f"{n}_d", real=True)
            qdd[n] = sp.Symbol(f"{n}_dd", real=True)
            sub[x.diff(t, 2)] = qdd[n]
            sub[x.diff(t)] = qd[n]
            sub[x] = q[n]
        e = [msubs(x, sub) for x in e]
        n = len(self.free)
        M = sp.Matrix(n, n, lambda a, b: -sp.diff(e[a], qdd[self.free[b]]))
        zero = {qdd[f]: 0 for f in self.free}
        F = sp.Matrix([x.subs(zero) for x in e])
        return Derivation(self.free, self.prescribed, q, qd, qdd, M, F, self.table, self.input_symbols,
                          reduced.lumped,
                          time.perf_counter() - start)
