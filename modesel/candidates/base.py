"""The one small interface every candidate family implements, and its registry.

A family turns (field, count, parameters, context) into `count` shapes on the
normalised span x = s/L in [0, 1], with first and second derivatives with
respect to x (divide by L and L**2 for physical slopes and curvatures).
Every shape satisfies phi(0) = phi'(0) = 0 for bending fields (phi(0) = 0 for
torsion) and is scaled to phi(1) = 1 (unit tip value), like ElastoDyn's
polynomials, so a generalised coordinate reads as the tip value of its shape.

Use the front function `mode_shapes(field, family, count, context, **params)`.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from modesel.errors import ModeselError, unknown_name
from modesel.modeset import FIELDS

BENDING_FIELDS = ("tower_fa", "tower_ss", "blade_flap", "blade_edge")
TORSION_FIELDS = ("tower_torsion",)


@dataclass(frozen=True)
class Parameter:
    """A continuous shape parameter a search may vary within [low, high]."""

    name: str
    default: float
    low: float
    high: float
    description: str = ""


@dataclass(frozen=True)
class FieldContext:
    """What a family may need to know about the field it describes.

    `beam` holds the distributed properties (needed by `fem`), `tip_mass` [kg]
    and `tip_inertia` [kg m^2] the concentrated tip load (tower: rotor-nacelle
    assembly), `rotor_speed` [rad/s] the speed for centrifugal stiffening of
    blades, `hub_radius` [m] and `precone` [rad] for blades, `gravity` [m/s^2],
    `elastodyn_coefficients` the deck's polynomial coefficients (x^2..x^6) per
    mode for this field.
    """

    field: str
    beam: object | None = None
    tip_mass: float = 0.0
    tip_inertia: float = 0.0
    rotor_speed: float = 0.0
    hub_radius: float = 0.0
    precone: float = 0.0
    gravity: float = 9.80665
    elastodyn_coefficients: tuple = ()
    source: str | None = None


@dataclass(frozen=True)
class ShapeSet:
    """`count` shapes of one field sampled at normalised stations `x`.

    phi, dphi, ddphi have shape (count, len(x)); derivatives are d/dx, d2/dx2.
    """

    field: str
    family: str
    x: np.ndarray
    phi: np.ndarray
    dphi: np.ndarray
    ddphi: np.ndarray
    params: dict = field(default_factory=dict)

    @property
    def count(self) -> int:
        return self.phi.shape[0]


class Family(ABC):
    """A family of assumed modes. Subclasses set the class attributes and
    implement `evaluate`."""

    name: str = ""
    description: str = ""
    fields: tuple = BENDING_FIELDS
    parameters: tuple = ()          # of Parameter
    max_count: int | None = None
    field_max_counts: dict = {}     # field -> a lower cap than max_count for that field

    def max_count_for(self, field: str) -> int | None:
        """Most shapes this family gives for `field` (None: unbounded)."""
        caps = [c for c in (self.max_count, self.field_max_counts.get(field)) if c is not None]
        return min(caps) if caps else None

    def relevant_parameters(self, field: str) -> tuple:
        """Names of the parameters that change the shapes of `field` (all by default)."""
        return tuple(p.name for p in self.parameters)

    def canonical(self, field: str, count: int, params: dict) -> tuple:
        """(family, count, params) of the simplest description of the same shapes:
        `params` are the full parameters (defaults filled in); parameters that do
        not change this field's shapes, and those at their default, are dropped.
        Families whose shapes equal another family's for some parameters
        (e.g. `relaxed_tipmass` with zero ratios is `clamped`) override this and
        name that family; tests check each declared equivalence on the shapes."""
        relevant = self.relevant_parameters(field)
        defaults = {p.name: p.default for p in self.parameters}
        kept = {k: float(v) for k, v in sorted(params.items())
                if k in relevant and float(v) != defaults.get(k)}
        return self.name, int(count), kept

    def shapes(self, x, count: int, context: FieldContext, **params) -> ShapeSet:
        """Validate and evaluate; the one entry point callers use."""
        full = self.validate(context.field, count, params)
        x = np.asarray(x, dtype=float)
        phi, dphi, ddphi = self.evaluate(x, int(count), context, full)
        return ShapeSet(context.field, self.name, x, np.atleast_2d(phi), np.atleast_2d(dphi),
                        np.atleast_2d(ddphi), full)

    def validate(self, field: str, count, params: dict) -> dict:
        """Check field, count and parameters (names, numbers, ranges) without
        evaluating anything; returns the full parameters (defaults filled in)."""
        if field not in FIELDS:
            raise unknown_name("field", field, FIELDS, field="field")
        if field not in self.fields:
            raise ModeselError(f"family '{self.name}' does not describe field '{field}'"
                               f" (it describes {', '.join(self.fields)})", field="family")
        if not isinstance(count, (int, np.integer)) or isinstance(count, bool) or count < 1:
            raise ModeselError(f"count must be an integer >= 1, got {count!r}", field="count")
        top = self.max_count_for(field)
        if top is not None and count > top:
            raise ModeselError(f"family '{self.name}' provides at most {top} modes"
                               f" for {field}, asked for {count}", field="count")
        known = {p.name: p for p in self.parameters}
        full = {p.name: p.default for p in self.parameters}
        for key, value in params.items():
            if key not in known:
                raise unknown_name(f"parameter of family '{self.name}'", key, known or ["(none)"],
                                   field="params")
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ModeselError(f"parameter '{key}' must be a number, got {value!r}",
                                   field=f"params.{key}") from None
            p = known[key]
            if not (p.low <= value <= p.high):
                raise ModeselError(f"parameter '{key}'={value:g} outside [{p.low:g}, {p.high:g}]",
                                   field=f"params.{key}")
            full[key] = value
        return full

    @abstractmethod
    def evaluate(self, x: np.ndarray, count: int, context: FieldContext, params: dict):
        """Return (phi, dphi, ddphi), each (count, len(x))."""

    def breakpoints(self, count: int, context: FieldContext, params: dict):
        """Normalised positions x in (0, 1) where the shapes are only piecewise
        smooth (a derivative jumps: finite-element boundaries), or None for
        shapes smooth on the whole span. Quadrature that puts interval ends
        there integrates them exactly; Gauss points straddling a jump do not
        (20 `fem` torsion modes on 40 such nodes: frequencies 3.7 % off).
        `params` are the full parameters (defaults filled in)."""
        return None


_REGISTRY: dict[str, Family] = {}

#: the family modules of this package; each registers its families on import
#: (add yours here). They are loaded on the first look-up, by name, so that
#: this module never imports the modules that import it.
FAMILY_MODULES = ("polynomial", "cosine", "clamped", "relaxed_root", "relaxed_tipmass",
                  "elastodyn", "linear", "sine", "fem")
_loaded = False


def _load_families() -> None:
    global _loaded
    if not _loaded:
        import importlib
        for name in FAMILY_MODULES:
            importlib.import_module(f"{__package__}.{name}")
        _loaded = True


def register(family_cls):
    """Class decorator: add a family to the registry under its `name`."""
    inst = family_cls()
    _REGISTRY[inst.name] = inst
    return family_cls


def get_family(name: str) -> Family:
    _load_families()
    try:
        return _REGISTRY[name]
    except KeyError:
        raise unknown_name("family", name, _REGISTRY) from None


def families(field: str | None = None) -> list[Family]:
    """All registered families, or those describing `field`."""
    _load_families()
    return [f for f in _REGISTRY.values() if field is None or field in f.fields]


def canonical_modes(field: str, family: str, count: int, params: dict | None = None, *,
                    lookup=None) -> tuple:
    """(family, count, params) of the simplest description of `count` shapes of
    `family` for `field` with `params` (validated; defaults filled in first):
    two choices with the same canonical form have identical shapes, so a
    search evaluates them once. `lookup(name) -> Family` (default
    `get_family`) lets a caller use family instances it already holds."""
    lookup = lookup or get_family
    fam = lookup(family)
    full = fam.validate(field, count, dict(params or {}))
    name, count, kept = fam.canonical(field, int(count), full)
    if name != fam.name:                  # an equivalence: canonical in the other family too
        other = lookup(name)
        return other.canonical(field, count, other.validate(field, count, kept))
    return name, count, kept


def default_stations(n: int = 201) -> np.ndarray:
    """Default normalised stations for sampling shapes."""
    return np.linspace(0.0, 1.0, n)


def check_field_modes(field: str, family: str, count, params=None, *, file=None, where=None) -> None:
    """Validate a family/count/parameters choice for `field` before any
    evaluation; errors name `file` and the dotted `where` (e.g.
    'modes.tower_fa') of the input that made the choice."""
    try:
        if not isinstance(family, str):
            raise ModeselError(f"family must be a name, got {family!r}", field="family")
        if not isinstance(params or {}, dict):
            raise ModeselError(f"params must be a table of numbers, got {params!r}", field="params")
        try:
            fam = get_family(family)
        except ModeselError as exc:
            raise ModeselError(exc.message, field="family") from None
        fam.validate(field, count, dict(params or {}))
    except ModeselError as exc:
        sub = exc.field if exc.field and exc.field != "field" else None
        raise ModeselError(exc.message, file=file if file is not None else exc.file,
                           field=".".join(p for p in (where, sub) if p) or None) from None


def shape_breakpoints(field: str, family: str, count: int, context: FieldContext | None = None,
                      **params):
    """Front function: `Family.breakpoints` of `count` shapes of `family` for
    `field` (validated like `mode_shapes`), or None."""
    context = context or FieldContext(field)
    fam = get_family(family)
    checked = fam.shapes(np.array([1.0]), count, context, **params)
    return fam.breakpoints(count, context, dict(checked.params))


def mode_shapes(field: str, family: str, count: int, context: FieldContext | None = None,
                x=None, **params) -> ShapeSet:
    """Front function: `count` shapes of `family` for `field` at stations `x`."""
    context = context or FieldContext(field)
    if context.field != field:
        raise ValueError("context.field must equal field")
    return get_family(family).shapes(default_stations() if x is None else x, count, context, **params)
