"""Shape integrals of a flexible body as symbols, and the node-field
algebra that turns the sums over a body's points into them.

The deformed position of a point of a flexible body (body frame) is

    s = s0 + sum_j Phi_j q_j - 1/2 a sum_ij S_ij q_i q_j            (first paper D4)

(a = beam axis, S_ij(s0) the axial-shortening integrals), i.e. a sum of
*basis fields* w_b (s0, Phi_j, a S_ij) with coefficients c_b(q). Every
velocity, acceleration and partial velocity of a point (eq. 2-3, 20) has
the form  v = v0 + sum_b C_b w_b  with C_b a 3x3 matrix that does not
depend on the point (e.g. skew(omega) for omega x s). Every term of the
flexible-body equations (eq. 11-19 and Appendix A) is a mass-weighted sum
over the body of a dot product of two such fields:

    sum_k m_k u_k . v_k = M u0.v0 + u0^T sum_b V_b I1[b] + v0^T sum_b U_b I1[b]
                          + sum_bb' tr(U_b^T V_b' I2[b', b])

with the shape integrals (first paper Appendix A and D3)
    M = int dm,  I1[b] = int w_b dm,  I2[b', b] = int w_b' w_b^T dm.
They contain the paper's integrals: I1[s0] = M s_CM (A3), I2[s0,s0] gives
J (A4), I1[Phi] = C_t^T (A6), I2[s0,Phi] gives C_r (A5), I2[Phi,Phi]
gives M_e (A7); the shortening terms give the self-weight (eq. 34) and
centrifugal (eq. 30) geometric stiffness and the second-order inertia.
For a zeroth-order field (no shortening) the expansion has only s0 and Phi.
Each non-zero entry becomes one symbol; structural zeros stay exact zeros.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from modesel.multibody.rotations import skew
from modesel.multibody.symbolic.parameters import AXES, ParameterTable

_ZERO3 = sp.zeros(3, 1)
# (basis kinds) -> (symbol stem, LaTeX stem, meaning); first paper Appendix A / D3
FAMILIES = {
    ("s0",): ("S", r"S", "int s0 dm (first moment, M s_CM, eq. A3)"),
    ("Phi",): ("Ct", r"C_{t", "int Phi_j dm (C_t, eq. A6)"),
    ("S",): ("Gw", r"G_{w", "int a S_ij dm (self-weight geometric stiffness / g, eq. 34)"),
    ("s0", "s0"): ("J", r"J", "int s0 s0^T dm (second moment, gives J of eq. A4)"),
    ("s0", "Phi"): ("Cr", r"C_{r", "int s0 Phi_j^T dm (gives C_r, eq. A5)"),
    ("Phi", "Phi"): ("Me", r"M_{e", "int Phi_i Phi_j^T dm (gives M_e, eq. A7)"),
    ("s0", "S"): ("Gs", r"G_{s", "int s0 (a S_ij)^T dm (centrifugal geometric stiffness, eq. 30)"),
    ("Phi", "S"): ("Gp", r"G_{p", "int Phi_l (a S_ij)^T dm (second-order inertia, App. D4)"),
    ("S", "S"): ("Gq", r"G_{q", "int (a S_ij)(a S_lm)^T dm (second-order inertia, App. D4)"),
}


class NodeField:
    """v_k = const + sum_b C_b w_b(k) over the points k of one body."""

    def __init__(self, const=None, terms=None):
        self.const = _ZERO3 if const is None else const
        self.terms = {} if terms is None else terms

    @classmethod
    def expansion(cls, coeffs: dict):
        """sum_b c_b w_b with scalar coefficients c_b."""
        return cls(None, {b: c * sp.eye(3) for b, c in coeffs.items() if c != 0})

    def __add__(self, other):
        terms = dict(self.terms)
        for b, C in other.terms.items():
            terms[b] = terms[b] + C if b in terms else C
        return NodeField(self.const + other.const, terms)

    def __sub__(self, other):
        return self + other.scaled(-1)

    def scaled(self, s):
        return NodeField(self.const * s, {b: C * s for b, C in self.terms.items()})

    def transformed(self, A):
        """A v_k for a point-independent 3x3 matrix A."""
        return NodeField(A * self.const, {b: A * C for b, C in self.terms.items()})

    def crossed(self, w):
        """w x v_k."""
        return self.transformed(sp.Matrix(skew(np.array(w, dtype=object).reshape(3))))


def constant(vec) -> NodeField:
    return NodeField(sp.Matrix(vec), {})


class ShapeIntegrals:
    """Symbols of M, I1[b], I2[b, b'] of one flexible body.

    Basis labels: 's0', ('Phi', j), ('S', i, j) with i <= j (shortening,
    along the beam axis). `label` names the body in the symbols (bodies
    with identical data, e.g. three blades, share one ShapeIntegrals)."""

    def __init__(self, body, label: str, table: ParameterTable, rel_zero: float = 1e-13):
        self.label = label
        self.table = table
        self.rel_zero = rel_zero
        m = np.asarray(body.node_mass, float)
        s0 = np.asarray(body.nodes, float)
        ne = body.n_elastic
        Phi = np.zeros((len(m), 3, ne)) if body.shapes is None else np.asarray(body.shapes, float)
        self.ne = ne
        self.basis = {"s0": s0}
        for j in range(ne):
            self.basis[("Phi", j)] = Phi[:, :, j]
        self.has_shortening = body.shortening is not None and ne > 0
        if self.has_shortening:
            S = np.asarray(body.shortening, float)
            a = np.asarray(body.axis, float)
            for i in range(ne):
                for j in range(i, ne):
                    self.basis[("S", i, j)] = S[:, i, j][:, None] * a[None, :]
        self.m = m
        self.mass = table.get(f"M_{label}", m.sum(), f"M_{{{label}}}", f"mass of body {label}")
        self._I1 = {}
        self._I2 = {}
        self.order = {b: k for k, b in enumerate(self.basis)}

    # ------------------------------------------------------------ naming
    @staticmethod
    def _item(b):
        if b == "s0":
            return ""
        if b[0] == "Phi":
            return str(b[1] + 1)
        return f"{b[1] + 1}{b[2] + 1}"

    @staticmethod
    def _family(b, b2=None):
        """(name stem, latex stem, meaning) of an integral family."""
        return FAMILIES[tuple(x if x == "s0" else x[0] for x in ((b,) if b2 is None else (b, b2)))]

    def _symbols(self, values, items, family, single_drop=True):
        """Symbol matrix of `values` (3 or 3x3); entries below rel_zero*max are exact 0."""
        stem, lstem, meaning = family
        scale = float(np.max(np.abs(values))) if values.size else 0.0
        nz = np.abs(values) > self.rel_zero * scale
        one = single_drop and int(nz.sum()) == 1
        if one and values.ndim == 2 and family[0] == "Me":
            i, j = np.argwhere(nz)[0]
            one = i == j                   # keep 'xy' on an off-diagonal Phi_i Phi_j^T entry
        L, item = self.label, "".join(items)
        out = sp.zeros(*(values.shape if values.ndim == 2 else (3, 1)))
        for idx in zip(*np.nonzero(nz)):
            comp = "".join(AXES[i] for i in idx) if values.ndim == 2 else AXES[idx[0]]
            suffix = "" if one else comp
            name = f"{stem}_{L}{item}{suffix}"
            open_ = lstem.count("{") > lstem.count("}")     # e.g. "C_{t" -> "C_{t,T1}"
            lat = (f"{lstem},{L}{item}{',' + suffix if suffix else ''}}}" if open_
                   else f"{lstem}_{{{L}{item}{',' + suffix if suffix else ''}}}")
            sym = self.table.get(name, values[idx], lat, meaning)
            if values.ndim == 2:
                out[idx[0], idx[1]] = sym
            else:
                out[idx[0], 0] = sym
        return out

    def I1(self, b):
        if b not in self._I1:
            vals = self.m @ self.basis[b]
            self._I1[b] = self._symbols(vals, [self._item(b)], self._family(b))
        return self._I1[b]

    def I2(self, b1, b2):
        """int w_b1 w_b2^T dm (3x3)."""
        if self.order[b1] > self.order[b2]:
            return self.I2(b2, b1).T
        key = (b1, b2)
        if key not in self._I2:
            vals = np.einsum("k,ki,kj->ij", self.m, self.basis[b1], self.basis[b2])
            if b1 == b2:                       # symmetric: symbols for the upper triangle only
                vals = np.triu(vals)
            items = [self._item(b1), self._item(b2)]
            mat = self._symbols(vals, items, self._family(b1, b2))
            if b1 == b2:
                mat = sp.Matrix(3, 3, lambda i, j: mat[min(i, j), max(i, j)])
            self._I2[key] = mat
        return self._I2[key]

    # ------------------------------------------------------------ sums
    def dot_sum(self, u: NodeField, v: NodeField):
        """sum_k m_k u_k . v_k."""
        total = self.mass * (u.const.T * v.const)[0, 0]
        for b, V in v.terms.items():
            total += (u.const.T * V * self.I1(b))[0, 0]
        for b, U in u.terms.items():
            total += (v.const.T * U * self.I1(b))[0, 0]
        for b, U in u.terms.items():
            for b2, V in v.terms.items():
                X = self.I2(b2, b)
                if X.is_zero_matrix:
                    continue
                P = U.T * V
                total += sum(P[i, j] * X[j, i] for i in range(3) for j in range(3) if X[j, i] != 0)
        return total

    def position_coefficients(self, q):
        """c_b(q) of s = sum_b c_b w_b (q: elastic coordinates of the body)."""
        c = {"s0": sp.Integer(1)}
        for j in range(self.ne):
            c[("Phi", j)] = q[j]
        if self.has_shortening:
            for i in range(self.ne):
                for j in range(i, self.ne):
                    c[("S", i, j)] = -q[i] * q[j] * (sp.Rational(1, 2) if i == j else 1)
        return c


def body_key(body) -> tuple:
    """Bodies with identical node data (three identical blades) share symbols."""
    arrays = [body.nodes, body.node_mass, body.shapes, body.shortening, body.stiffness, body.damping]
    return tuple(None if a is None else (np.asarray(a).shape, np.asarray(a, float).tobytes()) for a in arrays)
