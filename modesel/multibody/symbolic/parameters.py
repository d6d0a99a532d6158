"""Named physical constants of a symbolic model and their numeric values.

Every constant the symbolic equations use (a mass, a centre-of-mass
coordinate, a joint offset, the shaft tilt, a tower-top slope, a shape
integral) is a `sympy.Symbol` registered here with the value the numeric
engine uses, so `ParameterTable.values()` is the substitution dictionary
that makes the symbolic and the numeric equations the same numbers.

Naming follows the first paper (section 4.2): one capital letter per body
(T tower, N nacelle, R rotor = hub + rigid blades, F floater/platform,
B blade, Gen generator); x_NG is the x coordinate of the nacelle centre of
mass, x_NR the rotor position in the nacelle frame, J_{x,R} an inertia
about the centre of mass, theta_t the shaft tilt, nu_y the tower-top slope.
Units are SI (kg, m, rad, N/m ...).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from modesel.vocabulary import is_blade_body

# body letters (first paper section 4.2); other bodies keep their own name
BODY_LABELS = {"tower": "T", "nacelle": "N", "hub": "R", "generator": "Gen", "platform": "F"}
# small-angle groups (see approximations.small_angle): which parameters may be expanded
SMALL_GROUPS = ("tilt", "slope", "pitch")
SMALL_PRE_ROTATION = np.deg2rad(20.0)      # a constant angle below this may be treated as small
AXES = "xyz"


def body_label(name: str) -> str:
    """Short label of a body: T, N, R, F, Gen, B (blades share B)."""
    if name in BODY_LABELS:
        return BODY_LABELS[name]
    if is_blade_body(name):
        return "B"
    return name


@dataclass
class Parameter:
    """One constant: symbol, numeric value (SI), LaTeX form, meaning and
    the small-angle group it belongs to (None, 'tilt' or 'slope')."""

    symbol: sp.Symbol
    value: float
    latex: str
    meaning: str
    group: str | None = None


class ParameterTable:
    """Symbols of the constants, created on first use.

    `get(name, value, ...)` returns an exact 0 / +-1 for those values when
    `exact_units` is set (unit axes of prismatic joints, coefficient 1 of a
    revolute joint), else the registered symbol. The same name asked again
    with the same value returns the same symbol; `share` (a key such as
    ('pre', axis, value)) lets two bodies share one constant (the hub and
    the generator share the shaft tilt)."""

    def __init__(self):
        self.params: dict[str, Parameter] = {}
        self._shared: dict = {}

    def get(self, name: str, value: float, latex: str, meaning: str, *, group=None, share=None,
            exact_units: bool = False):
        value = float(value)
        if value == 0.0:
            return sp.Integer(0)
        if exact_units and value in (1.0, -1.0):
            return sp.Integer(int(value))
        if share is not None and share in self._shared:
            return self._shared[share]
        base, k = name, 1
        while name in self.params and self.params[name].value != value:
            k += 1
            name = f"{base}_{k}"
            latex = f"{latex}^{{({k})}}"
        if name not in self.params:
            self.params[name] = Parameter(sp.Symbol(name, real=True), value, latex, meaning, group)
        sym = self.params[name].symbol
        if share is not None:
            self._shared[share] = sym
        return sym

    def values(self) -> dict:
        """{name: value} - the substitution dictionary."""
        return {n: p.value for n, p in self.params.items()}

    def subs(self) -> dict:
        """{symbol: value}."""
        return {p.symbol: p.value for p in self.params.values()}

    def symbols(self) -> list:
        return [p.symbol for p in self.params.values()]

    def latex_names(self) -> dict:
        return {p.symbol: p.latex for p in self.params.values()}

    def group(self, name: str) -> list:
        return [p.symbol for p in self.params.values() if p.group == name]
