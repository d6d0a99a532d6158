"""Small-angle approximations, tidying and analytic linearisation of
symbolic equations of motion.

Small angles (first paper sections 4.5-4.6: "first-order small-angle
approximation for theta_t and a second-order approximation for nu"): every
symbol s of a group is replaced by eps*s and each entry of M and F is
truncated to its Taylor polynomial of the requested order in eps, then
eps = 1. Groups: 'tilt' (constant joint angles below 20 deg: shaft tilt,
precone), 'slope' (tip slopes nu of flexible bodies), 'pitch' (the
platform pitch coordinate). The truncation is done by differentiation,
T_n f = sum_k f^(k)(0)/k!, which needs no series machinery.

Linearisation (eq. 23-25): M0 = M(q0), C0 = -dF/dqd, K0 = -dF/dq (at an
operating point with zero acceleration, as eq. 24 assumes), Q0 = dF/du,
by exact symbolic Jacobians.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from modesel.errors import ModeselError
from modesel.multibody.symbolic.parameters import SMALL_GROUPS


def parse_orders(spec) -> dict:
    """Small-angle spec -> {group: order}. An int applies to 'tilt' and
    'slope'; a string 'tilt=1,slope=2,pitch=1' or a dict names groups."""
    if spec is None or spec == {}:
        return {}
    if isinstance(spec, int) and not isinstance(spec, bool):
        spec = {"tilt": spec, "slope": spec}
    if isinstance(spec, str):
        text = spec.strip()
        if text.isdigit():
            return parse_orders(int(text))
        out = {}
        for part in text.split(","):
            if "=" not in part:
                raise ModeselError(f"small-angle spec '{spec}': expected ORDER or group=order,...",
                                   field="small-angle")
            k, v = (x.strip() for x in part.split("=", 1))
            if not v.isdigit():
                raise ModeselError(f"small-angle order for '{k}' must be a non-negative integer, got '{v}'",
                                   field="small-angle")
            out[k] = int(v)
        spec = out
    if not isinstance(spec, dict):
        raise ModeselError(f"small-angle spec must be an integer or group=order pairs, got {spec!r}",
                           field="small-angle")
    for k, v in spec.items():
        if k not in SMALL_GROUPS:
            raise ModeselError(f"unknown small-angle group '{k}'; valid: {', '.join(SMALL_GROUPS)}",
                               field="small-angle")
        if not isinstance(v, int) or v < 0:
            raise ModeselError(f"small-angle order for '{k}' must be a non-negative integer, got {v!r}",
                               field="small-angle")
    return dict(spec)


def taylor(expr, symbols, order: int):
    """Truncate `expr` to `order` in the joint smallness of `symbols`:
    the Taylor polynomial in eps of expr(eps * symbols), at eps = 1."""
    if not symbols:
        return expr
    return sp.Add(*_TruncatedSeries(set(symbols), order).of(expr))


class _TruncatedSeries:
    """Coefficients [c_0..c_n] of expr(eps*s) = sum c_k eps^k + O(eps^(n+1)),
    computed node by node (sums add, products convolve, a function f(a0 + d)
    expands as sum f^(k)(a0) d^k / k!), so the expression never grows past
    the truncation order."""

    def __init__(self, symbols: set, order: int):
        self.small = symbols
        self.n = order
        self.cache = {}

    def _mul(self, a, b):
        out = [sp.Integer(0)] * (self.n + 1)
        for i, x in enumerate(a):
            if x == 0:
                continue
            for j in range(self.n + 1 - i):
                if b[j] != 0:
                    out[i + j] += x * b[j]
        return out

    def _compose(self, f, arg):
        """f(arg) for a one-argument function f given as a Lambda."""
        x = sp.Dummy("x")
        base, delta = arg[0], [sp.Integer(0)] + arg[1:]
        out = [sp.Integer(0)] * (self.n + 1)
        power = [sp.Integer(1)] + [sp.Integer(0)] * self.n
        deriv = f(x)
        fact = 1
        for k in range(self.n + 1):
            if k > 0:
                power = self._mul(power, delta)
                deriv = sp.diff(deriv, x)
                fact *= k
            if all(c == 0 for c in power):
                break
            coeff = deriv.subs(x, base) / fact
            out = [o + coeff * p for o, p in zip(out, power)]
        return out

    def of(self, e):
        if e in self.cache:
            return self.cache[e]
        zero = [sp.Integer(0)] * self.n
        if not (e.free_symbols & self.small):
            out = [e] + zero
        elif e in self.small:
            out = [sp.Integer(0), e] + zero[1:] if self.n >= 1 else [sp.Integer(0)]
        elif e.is_Add:
            out = [sp.Add(*c) for c in zip(*(self.of(a) for a in e.args))]
        elif e.is_Mul:
            out = [sp.Integer(1)] + zero
            for a in e.args:
                out = self._mul(out, self.of(a))
        elif e.is_Pow and e.exp.is_Integer and e.exp >= 0:
            out = [sp.Integer(1)] + zero
            base = self.of(e.base)
            for _ in range(int(e.exp)):
                out = self._mul(out, base)
        elif e.is_Pow and not (e.exp.free_symbols & self.small):
            out = self._compose(lambda y, p=e.exp: y ** p, self.of(e.base))
        elif isinstance(e, sp.Function) and len(e.args) == 1:
            out = self._compose(lambda y, f=e.func: f(y), self.of(e.args[0]))
        else:
            raise ModeselError(f"small-angle expansion of {e.func.__name__} is not supported")
        self.cache[e] = out
        return out


def small_angle(matrix: sp.Matrix, groups: dict, orders: dict) -> sp.Matrix:
    """Apply each group's truncation in turn. groups: {group: [symbols]}."""
    out = matrix
    for g, n in orders.items():
        syms = groups.get(g, [])
        if syms:
            out = out.applyfunc(lambda e, s=syms, n=n: taylor(e, s, n))
    return out


def tidy(expr):
    """Cheap exact simplification for display: expand, then cos^2 = 1 - sin^2
    for every trigonometric argument (the rotor azimuth drops out of an
    axisymmetric rotor's terms)."""
    expr = sp.expand(expr)
    for a in sorted({c.args[0] for c in expr.atoms(sp.cos)}, key=sp.default_sort_key):
        expr = sp.expand(expr.subs(sp.cos(a) ** 2, 1 - sp.sin(a) ** 2))
    return expr


@dataclass
class LinearSymbolic:
    """M0 dqdd + C0 dqd + K0 dq = Q0 du (eq. 24), as sympy matrices."""

    M0: sp.Matrix
    C0: sp.Matrix
    K0: sp.Matrix
    Q0: sp.Matrix


def linearize(M, F, q, qd, inputs, point: dict | None = None) -> LinearSymbolic:
    """Exact Jacobians (eq. 25) at zero inputs; `point` {symbol: value}
    substitutes the operating point (symbols not given stay symbolic)."""
    F0 = F.xreplace({u: 0 for u in inputs})
    C0 = -F0.jacobian(qd)
    K0 = -F0.jacobian(q)
    Q0 = F.jacobian(inputs) if inputs else sp.zeros(len(F), 0)
    M0 = M
    if point:
        M0, C0, K0, Q0 = (X.xreplace(point) for X in (M0, C0, K0, Q0))
    return LinearSymbolic(M0, C0, K0, Q0)
